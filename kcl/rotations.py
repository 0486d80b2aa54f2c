"""Small rotation and pose helpers shared by the model, the tasks and the tests.

Conventions (hal/interfaces.py): world NED, vehicle FRD, attitude roll/pitch/yaw
as Z-Y-X Euler angles (Fossen), so ``wRv = Rz(yaw) @ Ry(pitch) @ Rx(roll)``.
Vehicle pose ``eta = [x, y, z, roll, pitch, yaw]`` (m, rad, world NED); body
velocity ``v = [u, v, w, p, q, r]`` in the vehicle frame (m/s, rad/s).

Everything here is plain numpy on 3-vectors and 3x3 / 4x4 matrices; no state.
"""

from __future__ import annotations

import math

import numpy as np


def skew(w: np.ndarray) -> np.ndarray:
    """3x3 matrix ``S`` with ``S @ x == np.cross(w, x)``."""
    return np.array([[0.0, -w[2], w[1]], [w[2], 0.0, -w[0]], [-w[1], w[0], 0.0]])


def rpy_to_matrix(roll: float, pitch: float, yaw: float) -> np.ndarray:
    """Rotation ``wRv`` (3x3) from Z-Y-X Euler angles (rad)."""
    cr, sr = math.cos(roll), math.sin(roll)
    cp, sp = math.cos(pitch), math.sin(pitch)
    cy, sy = math.cos(yaw), math.sin(yaw)
    # one flat tuple, reshaped (cheaper than a nested list: called every control step)
    return np.array(
        (
            cy * cp,
            cy * sp * sr - sy * cr,
            cy * sp * cr + sy * sr,
            sy * cp,
            sy * sp * sr + cy * cr,
            sy * sp * cr - cy * sr,
            -sp,
            cp * sr,
            cp * cr,
        )
    ).reshape(3, 3)


def rpy_to_quaternion(roll: float, pitch: float, yaw: float) -> tuple[float, float, float, float]:
    """Unit quaternion ``(x, y, z, w)`` of the same rotation as :func:`rpy_to_matrix`
    (Z-Y-X Euler angles, rad; Pinocchio's coefficient order)."""
    cr, sr = math.cos(0.5 * roll), math.sin(0.5 * roll)
    cp, sp = math.cos(0.5 * pitch), math.sin(0.5 * pitch)
    cy, sy = math.cos(0.5 * yaw), math.sin(0.5 * yaw)
    return (
        sr * cp * cy - cr * sp * sy,
        cr * sp * cy + sr * cp * sy,
        cr * cp * sy - sr * sp * cy,
        cr * cp * cy + sr * sp * sy,
    )


def matrix_to_rpy(R: np.ndarray) -> np.ndarray:
    """Z-Y-X Euler angles ``[roll, pitch, yaw]`` (rad) of a rotation matrix.

    Pitch is in [-pi/2, pi/2]; at pitch = +-pi/2 (gimbal lock) roll is set to 0.
    """
    sp = -float(R[2, 0])
    sp = min(1.0, max(-1.0, sp))
    pitch = math.asin(sp)
    if abs(sp) > 1.0 - 1e-12:
        return np.array([0.0, pitch, math.atan2(-R[0, 1], R[1, 1])])
    return np.array([math.atan2(R[2, 1], R[2, 2]), pitch, math.atan2(R[1, 0], R[0, 0])])


def euler_rate_matrix(roll: float, pitch: float) -> np.ndarray:
    """3x3 ``T`` with ``[roll_dot, pitch_dot, yaw_dot] = T @ [p, q, r]`` (body rates).

    Singular at pitch = +-pi/2.
    """
    cr, sr = math.cos(roll), math.sin(roll)
    cp, tp = math.cos(pitch), math.tan(pitch)
    return np.array([[1.0, sr * tp, cr * tp], [0.0, cr, -sr], [0.0, sr / cp, cr / cp]])


def so3_exp(w: np.ndarray) -> np.ndarray:
    """Rotation matrix of the rotation vector ``w`` (rad), Rodrigues' formula."""
    theta = math.sqrt(float(w @ w))
    S = skew(w)
    if theta < 1e-9:
        return np.eye(3) + S + 0.5 * S @ S
    return np.eye(3) + (math.sin(theta) / theta) * S + ((1.0 - math.cos(theta)) / theta**2) * (S @ S)


def so3_log(R: np.ndarray) -> np.ndarray:
    """Rotation vector (rad) of a rotation matrix, angle in [0, pi]."""
    (r00, r01, r02), (r10, r11, r12), (r20, r21, r22) = np.asarray(
        R, dtype=float
    ).tolist()  # plain floats: cheaper than numpy scalars
    c = 0.5 * (r00 + r11 + r22 - 1.0)
    c = min(1.0, max(-1.0, c))
    theta = math.acos(c)
    v = np.array([r21 - r12, r02 - r20, r10 - r01])
    if theta < 1e-6:
        return 0.5 * v
    if math.pi - theta < 1e-4:
        # near pi: axis from the symmetric part (sign fixed by v when possible)
        B = 0.5 * (R + np.eye(3))
        k = int(np.argmax(np.diag(B)))
        axis = B[:, k] / math.sqrt(max(B[k, k], 1e-300))
        if axis @ v < 0:
            axis = -axis
        return theta * axis / np.linalg.norm(axis)
    return (theta / (2.0 * math.sin(theta))) * v


def homogeneous(R: np.ndarray, p: np.ndarray) -> np.ndarray:
    """4x4 homogeneous transform from a rotation and a translation."""
    T = np.eye(4)
    T[:3, :3] = R
    T[:3, 3] = p
    return T


def pose_matrix(eta: np.ndarray) -> np.ndarray:
    """World pose ``wTv`` (4x4) of the vehicle from ``eta = [x, y, z, roll, pitch, yaw]``."""
    return homogeneous(rpy_to_matrix(eta[3], eta[4], eta[5]), np.asarray(eta[:3], dtype=float))


def integrate_pose(eta: np.ndarray, v: np.ndarray, dt: float) -> np.ndarray:
    """Vehicle pose after moving with constant body velocity ``v`` for ``dt`` s.

    Exact for the rotation (exponential map on the body angular velocity); the
    position uses the midpoint rotation (second order), enough for simulation steps.
    """
    R0 = rpy_to_matrix(eta[3], eta[4], eta[5])
    dR = so3_exp(np.asarray(v[3:6], dtype=float) * dt)
    R1 = R0 @ dR
    Rmid = R0 @ so3_exp(np.asarray(v[3:6], dtype=float) * (0.5 * dt))
    p1 = np.asarray(eta[:3], dtype=float) + Rmid @ np.asarray(v[:3], dtype=float) * dt
    out = np.empty(6)
    out[:3] = p1
    out[3:] = matrix_to_rpy(R1)
    return out


def wrap_angle(a: float | np.ndarray) -> float | np.ndarray:
    """Angle(s) wrapped to [-pi, pi)."""
    return (np.asarray(a) + math.pi) % (2.0 * math.pi) - math.pi
