"""Arm velocity minimization (non-reactive, l rows): ``qdot = 0``.

Jacobian ``[I_l 0]``, reference 0, activation 1: keeps the arm still (hold,
lift).
"""

from __future__ import annotations

from kcl.tasks.base import Task
from kcl.tasks.jit import RowInputs, TaskRows, njit


@njit
def arm_stop_rows(inp: RowInputs, out: TaskRows) -> int:
    """Row kernel (kcl.tasks.jit): J = [I_l 0], activation 1; value, reference and
    error stay 0 (the rows arrive zeroed). No parameters, no frames."""
    q = inp.q
    J, a = out.J, out.a
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

    def dim(self) -> int:
        return self.l
