"""Small rigid-body helpers used by the simulator (pure functions, SI units).

Attitude is roll, pitch, yaw (Z-Y-X Euler angles, Fossen): ``R = Rz(yaw) Ry(pitch) Rx(roll)``
maps vehicle-frame (FRD) vectors into the world frame (NED). Poses are 4x4
homogeneous matrices ``aTb`` (frame b expressed in frame a).

Rotations come from :mod:`kcl.rotations` (one definition for the whole project);
this module adds the few pose helpers only the simulator needs.
"""

from __future__ import annotations

import math

import numpy as np

from kcl.rotations import matrix_to_rpy, rpy_to_matrix, so3_exp, wrap_angle

__all__ = [
    "rotation_rpy",
    "pose_from_eta",
    "rotation_from_vector",
    "rpy_from_rotation",
    "inverse_pose",
    "wrap_angle",
    "line_axis_angle",
    "norm",
]


# Rotations and vehicle poses are the KCL's own (one definition in the project).
rotation_rpy = rpy_to_matrix  #: world-from-body rotation (3, 3) of Z-Y-X Euler angles (rad)
rotation_from_vector = so3_exp  #: rotation matrix of a rotation vector (axis * angle, rad)


def rpy_from_rotation(R: np.ndarray) -> tuple[float, float, float]:
    """Z-Y-X Euler angles (roll, pitch, yaw) in rad of a rotation matrix, as floats."""
    roll, pitch, yaw = matrix_to_rpy(R)
    return float(roll), float(pitch), float(yaw)


_EYE4 = np.eye(4)


def pose_from_eta(eta: np.ndarray) -> np.ndarray:
    """World-from-vehicle pose (4, 4) of ``eta = [x y z roll pitch yaw]``: the KCL's
    :func:`kcl.rotations.pose_matrix`, filled the same way from a copied identity
    (``np.eye`` costs a few microseconds at every image)."""
    out = _EYE4.copy()
    out[:3, :3] = rpy_to_matrix(eta[3], eta[4], eta[5])
    out[:3, 3] = eta[:3]
    return out


def inverse_pose(T: np.ndarray) -> np.ndarray:
    """Inverse of a homogeneous pose (4, 4)."""
    out = _EYE4.copy()  # np.eye(4), cheaper
    Rt = T[:3, :3].T
    out[:3, :3] = Rt
    out[:3, 3] = (-Rt).dot(T[:3, 3])
    return out


def norm(v: np.ndarray) -> float:
    """Euclidean norm of a 1-D float vector: ``np.linalg.norm``'s own arithmetic (the
    square root of the dot product of the vector's contiguous copy), without its
    generic checks (a few microseconds on a 3-vector); the same number, as a float."""
    v = v.ravel()
    return math.sqrt(v.dot(v))


def line_axis_angle(u: np.ndarray, axis: np.ndarray) -> float:
    """Angle (rad, in [0, pi/2]) between direction ``u`` and the undirected line ``axis``."""
    c = abs(float(np.dot(u, axis))) / (norm(u) * norm(axis))
    return math.acos(min(1.0, c))
