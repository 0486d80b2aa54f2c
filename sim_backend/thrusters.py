"""Eight thrusters (4 horizontal + 4 vertical), their allocation and thrust curve.

Geometry (vehicle frame FRD, origin at the reference point, which is also the
centre of gravity of the hull; positive thrust pushes forward / down):

* horizontal, in the plane z = 0, at ``(+-hx, +-hy)``, each at ``alpha`` from
  the x axis (vectored), ordered FL, FR, RL, RR (L = port, y < 0). Thrust
  directions: FL ``(ca, sa)``, FR ``(ca, -sa)``, RL ``(ca, -sa)``, RR ``(ca, sa)``,
  so surge, sway and yaw use the orthogonal patterns ``(1,1,1,1)``,
  ``(1,-1,-1,1)``, ``(1,-1,1,-1)``; ``(1,1,-1,-1)`` is their null space.
* vertical, at ``(+-vx, +-vy)``, pushing along +z, ordered FL, FR, RL, RR:
  heave ``(1,1,1,1)``, roll ``vy (-1,1,-1,1)``, pitch ``-vx (1,1,-1,-1)``.

Allocation (MARIS, section II): per group, the torque demand is served first
(yaw for the horizontal thrusters, roll and pitch for the vertical ones), scaled
down only if it alone saturates a thruster; the remaining budget serves the
force demand (surge and sway together, or heave), scaled uniformly so no
thruster exceeds its limit (forward ``fmax``, reverse ``rmax``). The direction
of each demand is kept.

Thrust curve: a propeller's thrust grows with the square of its speed. The
normalized speed ``n`` follows the command ``u`` in [-1, 1] outside a dead zone
``dz``: ``n* = sign(u) max(0, |u| - dz) / (1 - dz)``; thrust
``T = g (fmax if n >= 0 else rmax) n |n|`` with a per-thruster gain ``g``
(manufacturing spread). The DCL inverts the *nominal* curve without the dead
zone (``u = sign(T) sqrt(|T| / limit)``), so small thrust demands produce much
less than asked, or nothing: thrusters perform poorly near zero, as MARIS found.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

#: Indices of the two groups in the 8-thruster arrays.
HORIZONTAL = slice(0, 4)
VERTICAL = slice(4, 8)


def geometry(alpha: float, hx: float, hy: float, vx: float, vy: float) -> np.ndarray:
    """Thrust configuration matrix B (6, 8): body wrench ``[X Y Z K M N]`` per
    unit thrust of each thruster (horizontal FL FR RL RR, then vertical FL FR RL RR)."""
    ca, sa = math.cos(alpha), math.sin(alpha)
    B = np.zeros((6, 8))
    pos_h = ((hx, -hy), (hx, hy), (-hx, -hy), (-hx, hy))
    dir_h = ((ca, sa), (ca, -sa), (ca, -sa), (ca, sa))
    for i, ((x, y), (dx, dy)) in enumerate(zip(pos_h, dir_h)):
        B[0, i], B[1, i] = dx, dy
        B[5, i] = x * dy - y * dx
    pos_v = ((vx, -vy), (vx, vy), (-vx, -vy), (-vx, vy))
    for j, (x, y) in enumerate(pos_v):
        B[2, 4 + j] = 1.0
        B[3, 4 + j] = y  # K = y Z - z Y
        B[4, 4 + j] = -x  # M = z X - x Z
    return B


@njit(cache=True)
def _largest_scale(base: np.ndarray, extra: np.ndarray, lo: float, hi: float) -> float:
    """Largest s in [0, 1] with ``lo <= base + s extra <= hi`` componentwise
    (``base`` is assumed inside the limits)."""
    s = 1.0
    for i in range(base.shape[0]):
        e = extra[i]
        if e > 0.0:
            room = hi - base[i]
            if e * s > room:
                s = max(0.0, room / e)
        elif e < 0.0:
            room = lo - base[i]  # negative
            if e * s < room:
                s = max(0.0, room / e)
    return s


@njit(cache=True)
def allocate(tau: np.ndarray, Binv: np.ndarray, fmax: float, rmax: float, out: np.ndarray) -> None:
    """Thrusts (8,) into ``out`` for the body wrench demand ``tau`` (6,), torque first.

    ``Binv`` (8, 6) is the pseudo-inverse of the configuration matrix (each
    column serves one DOF within its group). Horizontal group: yaw first, then
    surge + sway scaled together; vertical group: roll + pitch first, then heave.
    """
    th = np.zeros(4)
    tf = np.zeros(4)
    # horizontal: thrusters 0..3, DOFs X=0, Y=1 (force), N=5 (torque)
    for i in range(4):
        th[i] = Binv[i, 5] * tau[5]
        tf[i] = Binv[i, 0] * tau[0] + Binv[i, 1] * tau[1]
    zero = np.zeros(4)
    s1 = _largest_scale(zero, th, -rmax, fmax)
    for i in range(4):
        th[i] *= s1
    s2 = _largest_scale(th, tf, -rmax, fmax)
    for i in range(4):
        out[i] = th[i] + s2 * tf[i]
    # vertical: thrusters 4..7, DOFs Z=2 (force), K=3, M=4 (torques)
    for i in range(4):
        th[i] = Binv[4 + i, 3] * tau[3] + Binv[4 + i, 4] * tau[4]
        tf[i] = Binv[4 + i, 2] * tau[2]
    s1 = _largest_scale(zero, th, -rmax, fmax)
    for i in range(4):
        th[i] *= s1
    s2 = _largest_scale(th, tf, -rmax, fmax)
    for i in range(4):
        out[4 + i] = th[i] + s2 * tf[i]


@njit(cache=True)
def command_for_thrust(T: float, fmax: float, rmax: float) -> float:
    """The DCL's command in [-1, 1] for thrust ``T`` (N): the nominal quadratic
    curve inverted, dead zone not compensated."""
    if T >= 0.0:
        return min(1.0, math.sqrt(T / fmax))
    return -min(1.0, math.sqrt(-T / rmax))


@njit(cache=True)
def speed_for_command(u: float, dead_zone: float) -> float:
    """Steady normalized propeller speed in [-1, 1] for command ``u`` (dead zone applied)."""
    a = abs(u) - dead_zone
    if a <= 0.0:
        return 0.0
    n = a / (1.0 - dead_zone)
    return n if u > 0.0 else -n


@njit(cache=True)
def thrust_for_speed(n: float, gain: float, fmax: float, rmax: float) -> float:
    """Thrust (N) of a propeller at normalized speed ``n``."""
    return gain * (fmax if n >= 0.0 else rmax) * n * abs(n)


def wrench_limits(B: np.ndarray, fmax: float) -> np.ndarray:
    """Largest |wrench| (6,) each DOF gets alone with every thruster at ``fmax``
    (for the DCL's integrator clamp)."""
    return np.abs(B).sum(axis=1) * fmax
