"""Arm velocity minimization (non-reactive, l rows): ``qdot = 0``.

Jacobian ``[I_l 0]``, reference 0, activation 1: keeps the arm still (hold,
lift). The row kernel writes the same rows as :meth:`ArmVelocityMinimization.evaluate`,
so the controller's compiled arm step covers the actions that hold the arm.
"""

from __future__ import annotations

import numpy as np

from kcl.tasks.base import Task, TaskContext, TaskOutput
from kcl.tasks.jit import njit


@njit
def arm_stop_rows(p, frames, P, Jw, q, eta, wRv, env, x, J, a, xdot, err):
    """Row kernel (kcl.tasks.jit): J = [I_l 0], activation 1; value, reference and
    error stay 0 (the rows arrive zeroed). No parameters, no frames."""
    for i in range(q.shape[0]):
        J[i, i] = 1.0
        a[i] = 1.0
    return 0


class ArmVelocityMinimization(Task):
    TYPE = "arm_velocity_minimization"
    KIND = "velocity"
    USES_VEHICLE = False
    PARAMS = {}
    ROW_KERNEL = staticmethod(arm_stop_rows)
    KERNEL_ID = 10

    def setup(self) -> None:
        self.J = np.zeros((self.l, self.n))
        self.J[:, : self.l] = np.eye(self.l)
        self.zero = np.zeros(self.l)
        self.one = np.ones(self.l)

    def dim(self) -> int:
        return self.l

    def evaluate(self, ctx: TaskContext) -> TaskOutput:
        return TaskOutput(self.zero, self.J, self.one, self.zero, self.zero)
