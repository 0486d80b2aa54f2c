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

import numpy as np

from kcl.activation import decreasing_bell
from kcl.tasks.base import GAIN, MAX_RATE, Param, Task, TaskContext, TaskOutput, saturate


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

    def dim(self) -> int:
        return 1

    def distance(self, ctx: TaskContext, gradient_below: float = math.inf) -> tuple[float, np.ndarray] | None:
        """``(d, dd/dydot)`` or None without a target or on a degenerate geometry.
        The gradient is only computed when ``d < gradient_below`` (zeros otherwise)."""
        target = ctx.targets.camera_point()
        if target is None:
            return None
        kin = ctx.kin
        ox, oy, oz = kin.position_world(self.params["camera"]).tolist()
        ex, ey, ez = kin.position_world(self.params["elbow"]).tolist()
        tx, ty, tz = np.asarray(target, dtype=float).tolist()
        # scalar 3-vector algebra: cheaper than numpy at this size (arm rate)
        bx, by, bz = tx - ox, ty - oy, tz - oz
        nb = math.sqrt(bx * bx + by * by + bz * bz)
        if nb < 1e-6:
            return None
        ux, uy, uz = bx / nb, by / nb, bz / nb
        sx, sy, sz = ex - ox, ey - oy, ez - oz
        su = sx * ux + sy * uy + sz * uz
        rx, ry, rz = sx - su * ux, sy - su * uy, sz - su * uz
        d = math.sqrt(rx * rx + ry * ry + rz * rz)
        if d < 1e-9 or d >= gradient_below:
            return d, np.zeros(self.n)
        r = np.array([rx, ry, rz])
        rh = r * (1.0 / d)
        Je = kin.jacobian_world(self.params["elbow"])[:3]
        Jo = kin.jacobian_world(self.params["camera"])[:3]
        return d, rh @ (Je - (1.0 - su / nb) * Jo)

    def evaluate(self, ctx: TaskContext) -> TaskOutput:
        p = self.params
        xbar = p["min_distance"] + p["width"]
        res = self.distance(ctx, gradient_below=xbar)  # inactive beyond xbar: no gradient needed
        if res is None:
            return self.idle("no camera target")
        d, grad = res
        a = decreasing_bell(d, p["min_distance"], xbar)
        err = np.array([xbar - d if a > 0.0 else 0.0])
        return TaskOutput(np.array([d]), grad[None, :], np.array([a], dtype=float), saturate(p["gain"] * err, p["max_rate"]), err)
