"""The error of the log readers (:mod:`mission.logs.reader`, :mod:`mission.logs.stream`)."""

from __future__ import annotations


class LogError(Exception):
    """The file is not a readable MCAP run log."""
