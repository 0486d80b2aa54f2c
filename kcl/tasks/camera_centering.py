"""Camera centering (inequality ``angle <= max_angle``).

x = the angle (rad) between the stereo camera's optical axis (its z axis) and
the line of sight from the camera origin to the target point (world frame).
Activation: increasing bell over ``[max_angle - width, max_angle]``, reference
``gain (max_angle - width - angle)``. Target: ``Targets.camera_point()``.

Derivative: with a = optical axis, b = target - camera origin (both world),
cos(x) = a.b/|b|, a_dot = w x a and b_dot = -o_dot:
x_dot = -(w.(a x b)/|b| - (a/|b| - cos(x) b/|b|^2).o_dot) / sin(x).
At x ~ 0 (target centred) the Jacobian is set to zero: the task is inactive there.
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
    njit,
    saturate_into,
    upper_bound_row,
)


@njit
def camera_centering_rows(inp: RowInputs, out: TaskRows) -> int:
    """Row kernel (kcl.tasks.jit). p = [gain, max_rate, max_angle, width];
    frames = [camera]."""
    p, frames, P, Jw, env = inp.p, inp.frames, inp.P, inp.Jw, inp.env
    x, J, a, xdot, err = out.x, out.J, out.a, out.xdot, out.err
    if env[ENV_HAS_CAMERA_POINT] == 0.0:
        return IDLE_NO_CAMERA_TARGET
    f = frames[0]
    ax, ay, az = P[f, 0, 2], P[f, 1, 2], P[f, 2, 2]  # optical axis (z), world
    bx = env[ENV_CAMERA_POINT] - P[f, 0, 3]
    by = env[ENV_CAMERA_POINT + 1] - P[f, 1, 3]
    bz = env[ENV_CAMERA_POINT + 2] - P[f, 2, 3]
    nb = math.sqrt(bx * bx + by * by + bz * bz)
    if nb < 1e-6:
        return IDLE_NO_CAMERA_TARGET
    c = min(1.0, max(-1.0, (ax * bx + ay * by + az * bz) / nb))
    angle = math.acos(c)
    s = math.sin(angle)
    if s >= 1e-6:  # at ~0 (target centred, task inactive) the Jacobian stays zero
        k = c / (nb * nb)
        inv_s = 1.0 / s
        # [o_coef, -w_coef] / s with o_coef = a/|b| - cos(x) b/|b|^2, w_coef = (a x b)/|b|
        coef = (
            (ax / nb - k * bx) * inv_s,
            (ay / nb - k * by) * inv_s,
            (az / nb - k * bz) * inv_s,
            (-(ay * bz - az * by) / nb) * inv_s,
            (-(az * bx - ax * bz) / nb) * inv_s,
            (-(ax * by - ay * bx) / nb) * inv_s,
        )
        for j in range(J.shape[1]):
            acc = 0.0
            for r in range(6):
                acc += coef[r] * Jw[f, r, j]
            J[0, j] = acc
    upper_bound_row(angle, p[2], p[3], x, a, err)
    saturate_into(xdot, err, p[0], p[1])
    return 0


class CameraCentering(Task):
    TYPE = "camera_centering"
    KIND = "inequality"
    PARAMS = {
        "gain": GAIN,
        "max_rate": MAX_RATE,
        "max_angle": Param(0.35, "positive", "largest angle off the optical axis, rad"),
        "width": Param(0.15, "positive", "transition width, rad"),
        "camera": Param("stereo_camera", "frame", "camera frame (z = optical axis)"),
    }
    ROW_KERNEL = staticmethod(camera_centering_rows)

    def setup(self) -> None:
        # a camera fixed on the vehicle (no arm joint above its frame) gives a
        # Jacobian with zero arm columns: TPIK 2 can skip the task exactly
        model = self.model
        fid = model.frame_id(self.params["camera"])
        self.USES_ARM = model.pin_model.frames[fid].parentJoint > 0

    def dim(self) -> int:
        return 1
