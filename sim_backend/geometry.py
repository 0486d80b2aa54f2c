"""Small rigid-body helpers used by the simulator (pure functions, SI units).

Attitude is roll, pitch, yaw (Z-Y-X Euler angles, Fossen): ``R = Rz(yaw) Ry(pitch) Rx(roll)``
maps vehicle-frame (FRD) vectors into the world frame (NED). Poses are 4x4
homogeneous matrices ``aTb`` (frame b expressed in frame a).

Scalar trigonometry uses :mod:`math` on purpose: for 3x3 matrices it is several
times faster than many tiny numpy calls, and the simulator runs these at 100 Hz.
"""

from __future__ import annotations

import math

import numpy as np


def rotation_rpy(roll: float, pitch: float, yaw: float) -> np.ndarray:
    """World-from-body rotation (3, 3) for Z-Y-X Euler angles (rad)."""
    cr, sr = math.cos(roll), math.sin(roll)
    cp, sp = math.cos(pitch), math.sin(pitch)
    cy, sy = math.cos(yaw), math.sin(yaw)
    return np.array(
        [
            [cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr],
            [sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr],
            [-sp, cp * sr, cp * cr],
        ]
    )


def rpy_from_rotation(R: np.ndarray) -> tuple[float, float, float]:
    """Z-Y-X Euler angles (roll, pitch, yaw) in rad of a rotation matrix."""
    pitch = -math.asin(max(-1.0, min(1.0, float(R[2, 0]))))
    roll = math.atan2(float(R[2, 1]), float(R[2, 2]))
    yaw = math.atan2(float(R[1, 0]), float(R[0, 0]))
    return roll, pitch, yaw


def pose_from_eta(eta: np.ndarray) -> np.ndarray:
    """World-from-vehicle pose (4, 4) of ``eta = [x y z roll pitch yaw]`` (m, rad)."""
    T = np.eye(4)
    T[:3, :3] = rotation_rpy(eta[3], eta[4], eta[5])
    T[:3, 3] = eta[:3]
    return T


def inverse_pose(T: np.ndarray) -> np.ndarray:
    """Inverse of a homogeneous pose (4, 4)."""
    out = np.eye(4)
    Rt = T[:3, :3].T
    out[:3, :3] = Rt
    out[:3, 3] = -Rt @ T[:3, 3]
    return out


def rotation_from_vector(w: np.ndarray) -> np.ndarray:
    """Rotation matrix of a rotation vector ``w`` (axis * angle, rad), Rodrigues."""
    angle = float(np.linalg.norm(w))
    if angle < 1e-12:
        return np.eye(3)
    k = w / angle
    K = np.array([[0.0, -k[2], k[1]], [k[2], 0.0, -k[0]], [-k[1], k[0], 0.0]])
    return np.eye(3) + math.sin(angle) * K + (1.0 - math.cos(angle)) * (K @ K)


def wrap_angle(a: float) -> float:
    """Angle wrapped to [-pi, pi)."""
    return (a + math.pi) % (2.0 * math.pi) - math.pi


def line_axis_angle(u: np.ndarray, axis: np.ndarray) -> float:
    """Angle (rad, in [0, pi/2]) between direction ``u`` and the undirected line ``axis``."""
    c = abs(float(np.dot(u, axis))) / (float(np.linalg.norm(u)) * float(np.linalg.norm(axis)))
    return math.acos(min(1.0, c))
