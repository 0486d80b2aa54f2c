"""One AHRS sample (attitude, gyro rates with their noise spectrum, depth, position), compiled.

:meth:`sim_backend.sensors.Ahrs.update` calls :func:`ahrs_sample` at each AHRS
sample time (100 Hz): the arithmetic of :class:`sim_backend.gyro.GyroNoise` and
of the attitude/depth/position noise, in the same order on the same 13 standard
normals of the AHRS stream, so the samples are those of the former Python code
(the random draws are unchanged: the caller reserves them in its
:class:`sim_backend.rng.NormalBlock`).

State array ``st`` (``A_*`` indices): attitude (3) rad, rates (3) rad/s,
position (3) m world, drift (3) m (random walk of the first-order model's
position; z unused), gyro bias (3) rad/s, time of the last gyro sample (s; NaN
before the first). Parameters ``par`` (``P_*`` indices).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

A_ATT, A_RATES, A_POS, A_DRIFT, A_BIAS, A_GYRO_T = 0, 3, 6, 9, 12, 15
N_A = 16
P_ATT_NOISE, P_DEPTH_NOISE, P_DRIFT_STEP, P_WHITE, P_BIAS_STD, P_BIAS_TIME, P_VIB_W, P_VIB_AMP, P_PHASE = (
    0,
    3,
    4,
    5,
    6,
    7,
    8,
    9,
    10,
)
N_P = 13


@njit(cache=True)
def ahrs_sample(
    t: float,
    eta: np.ndarray,
    nu: np.ndarray,
    level: float,
    nav_xy: np.ndarray,
    has_nav: bool,
    buf: np.ndarray,
    i: int,
    st: np.ndarray,
    par: np.ndarray,
) -> float:
    """Take the sample of time ``t`` (s) in place in ``st``; ``buf[i:i + 13]``: its
    standard normals (attitude 3, drift 2, unused 1... see the order below);
    ``level``: thruster activity (0..1); ``nav_xy`` (2,): the navigation's own
    north/east (used when ``has_nav``). Returns the depth sample (m)."""
    # normals: 0-2 attitude, 3-4 position drift, 6 depth, 7-9 gyro white, 10-12 gyro bias increments
    yaw = eta[5] + par[P_ATT_NOISE + 2] * buf[i + 2]
    st[A_ATT] = eta[3] + par[P_ATT_NOISE] * buf[i]
    st[A_ATT + 1] = eta[4] + par[P_ATT_NOISE + 1] * buf[i + 1]
    st[A_ATT + 2] = (yaw + math.pi) % (2.0 * math.pi) - math.pi
    # gyro (sim_backend.gyro): Gauss-Markov bias, white noise, vibration line
    t_prev = st[A_GYRO_T]
    dt = 0.0 if math.isnan(t_prev) else max(0.0, t - t_prev)
    st[A_GYRO_T] = t
    bias_std = par[P_BIAS_STD]
    if dt > 0.0 and bias_std > 0.0:
        a = math.exp(-dt / par[P_BIAS_TIME])
        s = bias_std * math.sqrt(max(0.0, 1.0 - a * a))
        for k in range(3):
            st[A_BIAS + k] = a * st[A_BIAS + k] + s * buf[i + 10 + k]
    amp = par[P_VIB_AMP] * level
    for k in range(3):
        v = par[P_WHITE] * buf[i + 7 + k] + st[A_BIAS + k]
        if amp > 0.0:
            v += amp * math.sin(par[P_VIB_W] * t + par[P_PHASE + k])
        st[A_RATES + k] = nu[3 + k] + v
    depth = eta[2] + par[P_DEPTH_NOISE] * buf[i + 6]
    if has_nav:
        st[A_POS] = nav_xy[0]
        st[A_POS + 1] = nav_xy[1]
    else:
        ds = par[P_DRIFT_STEP]
        st[A_DRIFT] += ds * buf[i + 3]
        st[A_DRIFT + 1] += ds * buf[i + 4]
        st[A_POS] = eta[0] + st[A_DRIFT]
        st[A_POS + 1] = eta[1] + st[A_DRIFT + 1]
    st[A_POS + 2] = depth
    return depth
