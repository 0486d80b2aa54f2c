"""Activation functions of the iCAT task-priority framework (spec: icat.md).

Every control task carries an activation vector ``a`` in ``[0, 1]^m``: how much
each of its rows takes part in the task-priority inverse kinematics. This module
holds the smooth functions that produce those numbers:

* :func:`increasing_bell` / :func:`decreasing_bell`: raised-cosine steps between
  two breakpoints (C1-continuous, flat at both ends).
* :func:`lower_bound_activation` / :func:`upper_bound_activation`: the activation
  and the reactive target ``xbar`` of an inequality objective ``x >= xmin`` or
  ``x <= xmax`` with a transition width ``D`` (MARIS eq. 16-17).
* :func:`action_transition_factor` (alias :func:`a_p`): the factor that fades a
  task in or out when the current action changes (MARIS eq. 13).

All functions are pure. Bells and inequality activations are vectorised: ``x``,
``xmin`` and ``xmax`` broadcast like numpy arrays; plain Python floats go
through a scalar fast path and give back a float. Units are those of ``x``
(metres, radians, seconds, ...). NaN inputs give NaN activations, which
:func:`kcl.icat.tpik` then refuses with a ValueError naming the level: a lost
sensor must stop motion, never be silently read as "inactive".
"""

from __future__ import annotations

import math

import numpy as np

ArrayLike = float | np.ndarray

__all__ = [
    "increasing_bell",
    "decreasing_bell",
    "lower_bound_activation",
    "upper_bound_activation",
    "action_transition_factor",
    "a_p",
    "DEFAULT_TRANSITION_TIME",
]

#: Default action transition time T of MARIS, seconds.
DEFAULT_TRANSITION_TIME: float = 0.5

_SCALARS = (float, int)


def _check_breakpoints(xmin: ArrayLike, xmax: ArrayLike) -> None:
    if not np.all(np.asarray(xmax) > np.asarray(xmin)):
        raise ValueError(f"bell needs xmin < xmax (got xmin={xmin!r}, xmax={xmax!r})")


def decreasing_bell(x: ArrayLike, xmin: ArrayLike, xmax: ArrayLike) -> ArrayLike:
    """1 for ``x <= xmin``, 0 for ``x >= xmax``, ``0.5 cos(pi u) + 0.5`` between.

    ``u = (x - xmin) / (xmax - xmin)``. Requires ``xmin < xmax`` (ValueError).
    """
    if type(x) in _SCALARS and type(xmin) in _SCALARS and type(xmax) in _SCALARS:
        if not xmax > xmin:
            _check_breakpoints(xmin, xmax)
        if x <= xmin:
            return 1.0
        if x >= xmax:
            return 0.0
        if x != x:  # NaN
            return math.nan
        return 0.5 * math.cos(math.pi * (x - xmin) / (xmax - xmin)) + 0.5
    _check_breakpoints(xmin, xmax)
    x = np.asarray(x, dtype=float)
    u = np.clip((x - xmin) / (np.asarray(xmax, dtype=float) - xmin), 0.0, 1.0)
    return 0.5 * np.cos(np.pi * u) + 0.5


def increasing_bell(x: ArrayLike, xmin: ArrayLike, xmax: ArrayLike) -> ArrayLike:
    """0 for ``x <= xmin``, 1 for ``x >= xmax``, ``0.5 cos(pi u + pi) + 0.5`` between.

    ``u = (x - xmin) / (xmax - xmin)``. Requires ``xmin < xmax`` (ValueError).
    """
    if type(x) in _SCALARS and type(xmin) in _SCALARS and type(xmax) in _SCALARS:
        if not xmax > xmin:
            _check_breakpoints(xmin, xmax)
        if x <= xmin:
            return 0.0
        if x >= xmax:
            return 1.0
        if x != x:
            return math.nan
        return 0.5 - 0.5 * math.cos(math.pi * (x - xmin) / (xmax - xmin))
    _check_breakpoints(xmin, xmax)
    x = np.asarray(x, dtype=float)
    u = np.clip((x - xmin) / (np.asarray(xmax, dtype=float) - xmin), 0.0, 1.0)
    return 0.5 - 0.5 * np.cos(np.pi * u)


def _check_width(width: ArrayLike) -> None:
    if not np.all(np.asarray(width) > 0):
        raise ValueError(f"transition width must be > 0 (got {width!r})")


def lower_bound_activation(x: ArrayLike, xmin: ArrayLike, width: ArrayLike) -> tuple[ArrayLike, ArrayLike]:
    """Activation and target of the inequality objective ``x >= xmin``.

    The task is fully active (1) on the violated side ``x <= xmin``, fades out
    across ``[xmin, xmin + width]`` and is off (0) beyond. Returns
    ``(a, xbar)`` with ``xbar = xmin + width``: the point the reactive reference
    ``gamma (xbar - x)`` drives toward, inside the satisfied region.
    """
    _check_width(width)
    xbar = xmin + width
    return decreasing_bell(x, xmin, xbar), xbar


def upper_bound_activation(x: ArrayLike, xmax: ArrayLike, width: ArrayLike) -> tuple[ArrayLike, ArrayLike]:
    """Activation and target of the inequality objective ``x <= xmax``.

    Off (0) for ``x <= xmax - width``, fades in across ``[xmax - width, xmax]``,
    fully active (1) for ``x >= xmax``. Returns ``(a, xbar)`` with
    ``xbar = xmax - width``.
    """
    _check_width(width)
    xbar = xmax - width
    return increasing_bell(x, xbar, xmax), xbar


def action_transition_factor(in_old: bool, in_new: bool, t: float, T: float = DEFAULT_TRANSITION_TIME) -> float:
    """Action-transition factor ``a_p`` in [0, 1] of one task (MARIS eq. 13).

    ``t`` is the time (s) since the current action started, ``T`` (s) the
    transition time. A task only in the new action fades in
    (``IncreasingBell(t; 0, T)``), one only in the old action fades out
    (``DecreasingBell(t; 0, T)``), one in both stays at 1, one in neither is 0
    (its level is then skipped by the solver). ``T = 0`` switches at once.
    """
    if T < 0 or T != T:
        raise ValueError(f"transition time T must be >= 0 (got {T!r})")
    if in_old and in_new:
        return 1.0
    if not in_old and not in_new:
        return 0.0
    if T == 0:
        return 1.0 if in_new else 0.0
    t = float(t)
    T = float(T)
    return increasing_bell(t, 0.0, T) if in_new else decreasing_bell(t, 0.0, T)


#: Short name used in the papers.
a_p = action_transition_factor
