"""Elbow-camera occlusion avoidance (inequality ``d >= min_distance``).

x = d, the distance (m) from the elbow frame origin to the stereo camera's line
of sight towards the target point (the line through the camera origin and the
target; world frame). Keeping it above ``min_distance`` keeps the elbow out of
the picture. Activation: decreasing bell over ``[min_distance, min_distance +
width]``. Target: ``Targets.camera_point()``; idle without one.

The Jacobian is computed only while the task is active (d < min_distance +
width; zero otherwise, where the activation is zero too).

Derivative: with s = e - o (elbow minus camera origin), b = p - o, u = b/|b|,
r = s - (s.u) u and r_hat = r/|r|:  d_dot = r_hat . e_dot - (1 - s.u/|b|) r_hat . o_dot.
"""

from __future__ import annotations

import math

from kcl.tasks.base import GAIN, MAX_RATE, Param, Task
from kcl.tasks.jit import (
    ENV_CAMERA_POINT,
    ENV_HAS_CAMERA_POINT,
    IDLE_NO_CAMERA_TARGET,
    RowInputs,
    TaskRows,
    lower_bound_row,
    njit,
    saturate_into,
)


@njit
def occlusion_rows(inp: RowInputs, out: TaskRows) -> int:
    """Row kernel (kcl.tasks.jit). p = [gain, max_rate, min_distance, width];
    frames = [camera, elbow]."""
    p, frames, P, Jw, env = inp.p, inp.frames, inp.P, inp.Jw, inp.env
    x, J, a, xdot, err = out.x, out.J, out.a, out.xdot, out.err
    if env[ENV_HAS_CAMERA_POINT] == 0.0:
        return IDLE_NO_CAMERA_TARGET
    fc, fe = frames[0], frames[1]
    ox, oy, oz = P[fc, 0, 3], P[fc, 1, 3], P[fc, 2, 3]
    bx = env[ENV_CAMERA_POINT] - ox
    by = env[ENV_CAMERA_POINT + 1] - oy
    bz = env[ENV_CAMERA_POINT + 2] - oz
    nb = math.sqrt(bx * bx + by * by + bz * bz)
    if nb < 1e-6:
        return IDLE_NO_CAMERA_TARGET
    ux, uy, uz = bx / nb, by / nb, bz / nb
    sx, sy, sz = P[fe, 0, 3] - ox, P[fe, 1, 3] - oy, P[fe, 2, 3] - oz
    su = sx * ux + sy * uy + sz * uz
    rx, ry, rz = sx - su * ux, sy - su * uy, sz - su * uz
    d = math.sqrt(rx * rx + ry * ry + rz * rz)
    xbar = p[2] + p[3]
    if not (d < 1e-9 or d >= xbar):  # gradient only where the task can be active
        inv_d = 1.0 / d
        rh = (rx * inv_d, ry * inv_d, rz * inv_d)
        k = 1.0 - su / nb
        for j in range(J.shape[1]):
            acc = 0.0
            for r in range(3):
                acc += rh[r] * (Jw[fe, r, j] - k * Jw[fc, r, j])
            J[0, j] = acc
    lower_bound_row(d, p[2], p[3], x, a, err)
    saturate_into(xdot, err, p[0], p[1])
    return 0


class ElbowCameraOcclusion(Task):
    TYPE = "elbow_camera_occlusion"
    KIND = "inequality"
    PARAMS = {
        "gain": GAIN,
        "max_rate": MAX_RATE,
        "min_distance": Param(0.15, "positive", "minimum elbow distance from the line of sight, m"),
        "width": Param(0.1, "positive", "transition width, m"),
        "camera": Param("stereo_camera", "frame", "camera frame"),
        "elbow": Param("elbow", "frame", "frame kept out of the view"),
    }
    ROW_KERNEL = staticmethod(occlusion_rows)

    def dim(self) -> int:
        return 1
