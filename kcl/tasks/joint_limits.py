"""Arm joint limits (inequality, one row per joint).

x = q (rad). Each joint must stay in ``[lower + margin, upper - margin]`` (URDF
limits shrunk by ``margin``). Activation: decreasing bell over
``[lo, lo + width]`` plus increasing bell over ``[hi - width, hi]``; the reactive
reference ``gain (xbar - q)`` pushes back to ``lo + width`` or ``hi - width``.
Jacobian ``[I_l 0]``.
"""

from __future__ import annotations

import numpy as np

from kcl.tasks.base import GAIN, MAX_RATE, Param, Task, TaskContext, TaskOutput, saturate


class ArmJointLimits(Task):
    TYPE = "arm_joint_limits"
    KIND = "inequality"
    USES_VEHICLE = False
    PARAMS = {
        "gain": GAIN,
        "max_rate": MAX_RATE,
        "margin": Param(0.05, "nonneg", "safety margin inside the URDF limits, rad"),
        "width": Param(0.2, "positive", "transition width of the activation, rad"),
    }

    def setup(self) -> None:
        p = self.params
        m = self.model
        self.lo = m.joint_lower + p["margin"]
        self.hi = m.joint_upper - p["margin"]
        if np.any(self.hi - self.lo <= 2 * p["width"]):
            raise ValueError("margin and width leave no free range for some joint")
        self.mid = 0.5 * (self.lo + self.hi)
        self.free_lo = self.lo + p["width"]  # inside [free_lo, free_hi] every activation is 0
        self.free_hi = self.hi - p["width"]
        self.J = np.zeros((self.l, self.n))
        self.J[:, : self.l] = np.eye(self.l)
        self.zeros = np.zeros(self.l)
        self.zeros.setflags(write=False)

    def dim(self) -> int:
        return self.l

    def evaluate(self, ctx: TaskContext) -> TaskOutput:
        q = ctx.kin.q
        if (self.free_lo <= q).all() and (q <= self.free_hi).all():  # the usual case: far from every limit
            return TaskOutput(q.copy(), self.J, self.zeros, self.zeros, self.zeros)
        w = self.params["width"]
        # decreasing bell over [lo, lo + w] plus increasing bell over [hi - w, hi]
        # (kcl.activation's raised cosines, inlined on the vector: this runs at
        # the arm rate), i.e. 0.5 + 0.5 cos(pi u) with u the depth into the band
        depth = np.maximum(self.lo + w - q, q - (self.hi - w)) * (1.0 / w)
        a = 0.5 + 0.5 * np.cos(np.pi * np.clip(1.0 - depth, 0.0, 1.0))
        xbar = np.where(q < self.mid, self.lo + w, self.hi - w)
        err = np.where(a > 0.0, xbar - q, 0.0)
        xdot = saturate(self.params["gain"] * err, self.params["max_rate"])
        return TaskOutput(q.copy(), self.J, a, xdot, err)
