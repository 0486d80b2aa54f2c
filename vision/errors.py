"""Exceptions of the vision package."""

from __future__ import annotations


class VisionInputError(ValueError):
    """An image or an image pair the detector cannot use (missing, corrupt,
    wrong size). The message says which image and what is wrong."""
