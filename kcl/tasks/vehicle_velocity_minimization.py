"""Vehicle velocity minimization (non-reactive, 6 rows): ``v = 0``.

Jacobian ``[0_{6 x l} I_6]``, reference 0, activation 1: holds the vehicle still
(station keeping in velocity), e.g. while the arm moves to transport posture.
"""

from __future__ import annotations

import numpy as np

from kcl.tasks.base import Task, TaskContext, TaskOutput


class VehicleVelocityMinimization(Task):
    TYPE = "vehicle_velocity_minimization"
    KIND = "velocity"
    USES_ARM = False
    PARAMS = {}

    def setup(self) -> None:
        self.J = np.zeros((6, self.n))
        self.J[:, self.l :] = np.eye(6)
        self.zero = np.zeros(6)
        self.one = np.ones(6)

    def dim(self) -> int:
        return 6

    def evaluate(self, ctx: TaskContext) -> TaskOutput:
        x = ctx.v if ctx.v is not None else self.zero
        return TaskOutput(np.array(x, dtype=float), self.J, self.one, self.zero, -np.asarray(x, dtype=float))
