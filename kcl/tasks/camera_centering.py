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

import numpy as np

from kcl.activation import increasing_bell
from kcl.tasks.base import GAIN, MAX_RATE, Param, Task, TaskContext, TaskOutput, saturate


class CameraCentering(Task):
    TYPE = "camera_centering"
    KIND = "inequality"
    PARAMS = {
        "gain": GAIN,
        "max_angle": Param(0.35, "positive", "largest angle off the optical axis, rad"),
        "width": Param(0.15, "positive", "transition width, rad"),
        "max_rate": MAX_RATE,
        "camera": Param("stereo_camera", "frame", "camera frame (z = optical axis)"),
    }

    def setup(self) -> None:
        # a camera fixed on the vehicle (no arm joint above its frame) gives a
        # Jacobian with zero arm columns: TPIK 2 can skip the task exactly
        model = self.model
        fid = model.frame_id(self.params["camera"])
        self.USES_ARM = model.pin_model.frames[fid].parentJoint > 0

    def dim(self) -> int:
        return 1

    def angle(self, ctx: TaskContext, gradient_above: float = -math.inf) -> tuple[float, np.ndarray] | None:
        """``(x, dx/dydot)`` or None without a target; the gradient is zeros
        when ``x <= gradient_above`` (the task is inactive there)."""
        target = ctx.targets.camera_point()
        if target is None:
            return None
        kin = ctx.kin
        cam = self.params["camera"]
        (_, _, ax, ox), (_, _, ay, oy), (_, _, az, oz), _ = kin.pose_world(cam).tolist()  # plain floats
        tx, ty, tz = np.asarray(target, dtype=float).tolist()
        bx, by, bz = tx - ox, ty - oy, tz - oz
        nb = math.sqrt(bx * bx + by * by + bz * bz)
        if nb < 1e-6:
            return None
        c = min(1.0, max(-1.0, (ax * bx + ay * by + az * bz) / nb))
        x = math.acos(c)
        s = math.sin(x)
        if s < 1e-6 or x <= gradient_above:
            return x, np.zeros(self.n)
        J = kin.jacobian_world(cam)
        k = c / (nb * nb)
        # [o_coef, -w_coef] / s with o_coef = a/|b| - cos(x) b/|b|^2, w_coef = (a x b)/|b|
        coef = np.array(
            [
                ax / nb - k * bx,
                ay / nb - k * by,
                az / nb - k * bz,
                -(ay * bz - az * by) / nb,
                -(az * bx - ax * bz) / nb,
                -(ax * by - ay * bx) / nb,
            ]
        ) * (1.0 / s)
        return x, coef @ J

    def evaluate(self, ctx: TaskContext) -> TaskOutput:
        return self._evaluate(ctx, -math.inf)

    def evaluate_for_solver(self, ctx: TaskContext) -> TaskOutput:
        """:meth:`evaluate` without the gradient while inactive (angle <= max_angle - width)."""
        return self._evaluate(ctx, self.params["max_angle"] - self.params["width"])

    def _evaluate(self, ctx: TaskContext, gradient_above: float) -> TaskOutput:
        p = self.params
        xbar = p["max_angle"] - p["width"]
        res = self.angle(ctx, gradient_above=gradient_above)
        if res is None:
            return self.idle("no camera target")
        x, grad = res
        a = increasing_bell(x, xbar, p["max_angle"])
        err = np.array([xbar - x if a > 0.0 else 0.0])
        return TaskOutput(np.array([x]), grad[None, :], np.array([a], dtype=float), saturate(p["gain"] * err, p["max_rate"]), err)
