"""Activation functions of the iCAT task-priority framework (spec: icat.md).

Every control task carries an activation vector ``a`` in ``[0, 1]^m``: how much
each of its rows takes part in the task-priority inverse kinematics.

* :func:`increasing_bell` / :func:`decreasing_bell`: raised-cosine steps between
  two breakpoints (C1-continuous, flat at both ends). An inequality ``x >= xmin``
  with transition width D is active by ``decreasing_bell(x, xmin, xmin + D)``
  and drives towards ``xbar = xmin + D``; ``x <= xmax`` by
  ``increasing_bell(x, xmax - D, xmax)`` towards ``xmax - D`` (MARIS eq. 16-17).
* :func:`band_activation`: both bounds of ``lo <= x <= hi`` at once (joint
  limits, the geofence).
* :func:`action_transition_factor`: the factor that fades a task in or out when
  the current action changes (MARIS eq. 13).

The bells are compiled (the tasks' row kernels call them) and take floats, from
Python too; units are those of ``x``. A NaN ``x`` gives a NaN activation, which
the solver refuses (a lost sensor stops motion, never reads as "inactive").
"""

from __future__ import annotations

import math

from kcl.jit import njit

#: Default action transition time T of MARIS, seconds.
DEFAULT_TRANSITION_TIME: float = 0.5


@njit
def increasing_bell(x: float, xmin: float, xmax: float) -> float:
    """0 for ``x <= xmin``, 1 for ``x >= xmax``, ``0.5 - 0.5 cos(pi u)`` between,
    ``u = (x - xmin) / (xmax - xmin)``; needs ``xmin < xmax``."""
    if x <= xmin:
        return 0.0
    if x >= xmax:
        return 1.0
    if x != x:
        return math.nan
    return 0.5 - 0.5 * math.cos(math.pi * (x - xmin) / (xmax - xmin))


@njit
def decreasing_bell(x: float, xmin: float, xmax: float) -> float:
    """1 for ``x <= xmin``, 0 for ``x >= xmax``, ``0.5 cos(pi u) + 0.5`` between,
    ``u = (x - xmin) / (xmax - xmin)``; needs ``xmin < xmax``."""
    if x <= xmin:
        return 1.0
    if x >= xmax:
        return 0.0
    if x != x:
        return math.nan
    return 0.5 * math.cos(math.pi * (x - xmin) / (xmax - xmin)) + 0.5


@njit
def band_activation(x: float, lo: float, hi: float, width: float) -> tuple[float, float]:
    """Activation and target of ``lo <= x <= hi`` (a two-sided inequality with
    transition width ``width`` inside each bound): a decreasing bell over
    ``[lo, lo + width]`` plus an increasing bell over ``[hi - width, hi]``, and the
    point the reference drives to, ``lo + width`` or ``hi - width`` (the nearer
    side); needs ``hi - lo > 2 width``."""
    d_lo, d_hi = lo + width - x, x - (hi - width)
    u = 1.0 - (d_lo if d_lo >= d_hi else d_hi) * (1.0 / width)
    if u < 0.0:
        u = 0.0
    elif u > 1.0:
        u = 1.0
    xbar = lo + width if x < 0.5 * (lo + hi) else hi - width
    return 0.5 + 0.5 * math.cos(math.pi * u), xbar


def action_transition_factor(start: float, end: float, t: float, T: float = DEFAULT_TRANSITION_TIME) -> float:
    """Action-transition factor ``a_p`` of one task (MARIS eq. 13), ``t`` (s) after
    the action switch, transition time ``T`` (s): from ``start`` (its factor at the
    switch) to ``end`` (1 if the new action has the task, else 0) along an
    increasing bell over ``[0, T]``. With ``start`` 0 or 1 this is the spec's
    ``IncreasingBell(t; 0, T)`` (task only in the new action) or
    ``DecreasingBell(t; 0, T)`` (only in the old one); a switch in the middle of a
    transition starts from the current factor, so references stay continuous."""
    if start == end or T <= 0.0:
        return end
    return start + (end - start) * increasing_bell(t, 0.0, T)
