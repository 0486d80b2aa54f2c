"""Arm velocity minimization (non-reactive, l rows): ``qdot = 0``.

Jacobian ``[I_l 0]``, reference 0, activation 1: keeps the arm still (hold).
"""

from __future__ import annotations

import numpy as np

from kcl.tasks.base import Task, TaskContext, TaskOutput


class ArmVelocityMinimization(Task):
    TYPE = "arm_velocity_minimization"
    KIND = "velocity"
    USES_VEHICLE = False
    PARAMS = {}

    def setup(self) -> None:
        self.J = np.zeros((self.l, self.n))
        self.J[:, : self.l] = np.eye(self.l)
        self.zero = np.zeros(self.l)
        self.one = np.ones(self.l)

    def dim(self) -> int:
        return self.l

    def evaluate(self, ctx: TaskContext) -> TaskOutput:
        return TaskOutput(self.zero, self.J, self.one, self.zero, self.zero)
