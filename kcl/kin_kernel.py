"""Compiled set-up of a :class:`kcl.model.Kinematics` snapshot (one call per
control step instead of a dozen small Python/numpy operations).

:func:`configure` writes the vehicle rotation ``wRv`` (3x3, Z-Y-X Euler angles)
and Pinocchio's free-flyer configuration ``[x y z qx qy qz qw q]`` from ``eta``
and ``q``: the same arithmetic, in the same order, as
:func:`kcl.rotations.rpy_to_matrix` and :func:`kcl.rotations.rpy_to_quaternion`
(``math.cos``/``math.sin`` are the C library's in both), so the same numbers.
"""

from __future__ import annotations

import math

import numpy as np

from kcl.jit import njit


@njit
def configure(q: np.ndarray, eta: np.ndarray, wRv: np.ndarray, qff: np.ndarray) -> None:
    """``wRv`` = rotation of ``eta[3:6]`` (roll, pitch, yaw, rad); ``qff`` (7 + l,)
    = ``[eta[0:3], quaternion (x, y, z, w), q]``."""
    roll = eta[3]
    pitch = eta[4]
    yaw = eta[5]
    cr, sr = math.cos(roll), math.sin(roll)
    cp, sp = math.cos(pitch), math.sin(pitch)
    cy, sy = math.cos(yaw), math.sin(yaw)
    wRv[0, 0] = cy * cp
    wRv[0, 1] = cy * sp * sr - sy * cr
    wRv[0, 2] = cy * sp * cr + sy * sr
    wRv[1, 0] = sy * cp
    wRv[1, 1] = sy * sp * sr + cy * cr
    wRv[1, 2] = sy * sp * cr - cy * sr
    wRv[2, 0] = -sp
    wRv[2, 1] = cp * sr
    wRv[2, 2] = cp * cr
    cr, sr = math.cos(0.5 * roll), math.sin(0.5 * roll)
    cp, sp = math.cos(0.5 * pitch), math.sin(0.5 * pitch)
    cy, sy = math.cos(0.5 * yaw), math.sin(0.5 * yaw)
    qff[0] = eta[0]
    qff[1] = eta[1]
    qff[2] = eta[2]
    qff[3] = sr * cp * cy - cr * sp * sy
    qff[4] = cr * sp * cy + sr * cp * sy
    qff[5] = cr * cp * sy - sr * sp * cy
    qff[6] = cr * cp * cy + sr * sp * sy
    for i in range(q.shape[0]):
        qff[7 + i] = q[i]
