"""Views carved from one flat buffer, in order (compiled).

The KCL keeps each object that its compiled calls read (the task batch, a TPIK's
plan and stack, the kinematic chain) in one float64 and one int64 buffer: a
compiled call then takes the object as two arguments, and carves the same views
again inside. The same functions carve the views on the Python side, so both
sides agree on every layout by construction.
"""

from __future__ import annotations

import numpy as np

from kcl.jit import njit


@njit
def take(buf: np.ndarray, o: int, size: int) -> tuple[np.ndarray, int]:
    """``buf[o : o + size]`` and the next offset."""
    return buf[o : o + size], o + size


@njit
def take2(buf: np.ndarray, o: int, rows: int, cols: int) -> tuple[np.ndarray, int]:
    """The next ``rows`` x ``cols`` block (C order) and the next offset."""
    size = rows * cols
    return buf[o : o + size].reshape((rows, cols)), o + size


@njit
def take3(buf: np.ndarray, o: int, a: int, b: int, c: int) -> tuple[np.ndarray, int]:
    """The next ``a`` x ``b`` x ``c`` block (C order) and the next offset."""
    size = a * b * c
    return buf[o : o + size].reshape((a, b, c)), o + size
