"""Vehicle velocity minimization (non-reactive, 6 rows): ``v = 0``.

Jacobian ``[0_{6 x l} I_6]``, reference 0, activation 1: holds the vehicle still
(station keeping in velocity), e.g. while the arm moves to transport posture.
Value: the vehicle velocity fed to the TPIK (error its opposite). The row
kernel writes the same rows as :meth:`VehicleVelocityMinimization.evaluate`,
so the controller's compiled vehicle step covers the actions that hold the
vehicle.
"""

from __future__ import annotations

import numpy as np

from kcl.tasks.base import Task, TaskContext, TaskOutput
from kcl.tasks.jit import ENV_VELOCITY, njit


@njit
def vehicle_stop_rows(p, frames, P, Jw, q, eta, wRv, env, x, J, a, xdot, err):
    """Row kernel (kcl.tasks.jit): J = [0 I_6], activation 1, reference 0; value the
    fed velocity (``env``'s velocity part), error its opposite. No parameters, no frames."""
    l = q.shape[0]
    for i in range(6):
        J[i, l + i] = 1.0
        a[i] = 1.0
        v = env[ENV_VELOCITY + i]
        x[i] = v
        err[i] = -v
    return 0


class VehicleVelocityMinimization(Task):
    TYPE = "vehicle_velocity_minimization"
    KIND = "velocity"
    USES_ARM = False
    PARAMS = {}
    ROW_KERNEL = staticmethod(vehicle_stop_rows)
    KERNEL_ID = 11

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
