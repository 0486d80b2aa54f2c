"""Measured vehicle velocity (non-reactive, 6 rows; MARIS III-B8 and III-B9).

``J = [0_{6 x l} I_6]``, reference = the vehicle velocity ``TaskContext.v``
(measured and filtered, or the last commanded one). Activation: 1 on the
vehicle DOFs that are NOT actuated (TPIK 1: the solver cannot use them and
accounts for their motion), or 1 on all six (TPIK 2: only the arm is
optimised, for the vehicle motion that really happens). The controller puts it
on top of TPIK 1 itself (it is not listed in the actions file); for TPIK 2 it
solves the equivalent reduced problem (vehicle motion moved to the right-hand
side, see ``UvmsController._levels``), so ``all_dofs=True`` serves as the
reference form in tests and for other solvers.
"""

from __future__ import annotations

import numpy as np

from kcl.tasks.base import Param, Task, TaskContext, TaskOutput


class MeasuredVehicleVelocity(Task):
    TYPE = "measured_vehicle_velocity"
    KIND = "velocity"
    USES_ARM = False
    PARAMS = {"all_dofs": Param(False, "bool", "activate all six DOFs (TPIK 2) instead of the non-actuated ones")}

    def setup(self) -> None:
        self.J = np.zeros((6, self.n))
        self.J[:, self.l :] = np.eye(6)

    def dim(self) -> int:
        return 6

    def evaluate(self, ctx: TaskContext) -> TaskOutput:
        v = np.zeros(6) if ctx.v is None else np.asarray(ctx.v, dtype=float)
        if self.params["all_dofs"]:
            a = np.ones(6)
        else:
            actuated = np.ones(6, dtype=bool) if ctx.actuated is None else np.asarray(ctx.actuated, dtype=bool)
            a = (~actuated).astype(float)
        return TaskOutput(v.copy(), self.J, a, v.copy(), np.zeros(6))
