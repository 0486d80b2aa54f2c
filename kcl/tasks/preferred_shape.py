"""Arm preferred shape / posture (equality on selected joints, rad).

x = the joints listed with a value in ``posture`` (one entry per arm joint,
``null`` = free); reference ``gain (posture - q)``, saturated to ``max_rate``
(rad/s). Used for the grasp action's preferred shape and, with other postures,
for the folded (survey) and transport postures. Jacobian: rows of ``[I_l 0]``.
"""

from __future__ import annotations

import numpy as np

from kcl.tasks.base import GAIN, MAX_RATE, Param, Task, TaskContext, TaskOutput, saturate


class ArmPreferredShape(Task):
    TYPE = "arm_preferred_shape"
    USES_VEHICLE = False
    PARAMS = {
        "gain": GAIN,
        "max_rate": MAX_RATE,
        "posture": Param(None, "posture", "preferred angle of each joint (rad), null = free"),
    }

    def setup(self) -> None:
        posture = self.params["posture"]
        if posture is None:
            raise ValueError("posture is required")
        if len(posture) != self.l:
            raise ValueError(f"posture needs {self.l} entries (one per joint), got {len(posture)}")
        self.index = np.array([i for i, v in enumerate(posture) if v is not None], dtype=int)
        if self.index.size == 0:
            raise ValueError("posture leaves every joint free")
        self.target_angles = np.array([posture[i] for i in self.index], dtype=float)
        m = self.model
        if np.any(self.target_angles < m.joint_lower[self.index]) or np.any(self.target_angles > m.joint_upper[self.index]):
            raise ValueError("posture outside the joint limits")
        self.J = np.zeros((self.index.size, self.n))
        self.J[np.arange(self.index.size), self.index] = 1.0

    def dim(self) -> int:
        return int(self.index.size)

    def evaluate(self, ctx: TaskContext) -> TaskOutput:
        x = ctx.kin.q[self.index]
        err = self.target_angles - x
        xdot = saturate(self.params["gain"] * err, self.params["max_rate"])
        return TaskOutput(x, self.J, np.ones(self.index.size), xdot, err)
