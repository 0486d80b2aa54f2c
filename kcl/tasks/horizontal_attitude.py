"""Vehicle horizontal attitude (inequality ``|roll|, |pitch| <= max_angle``).

x = [roll, pitch] of the vehicle (rad, Z-Y-X). Activation per row: increasing
bell of ``|x|`` over ``[max_angle - width, max_angle]``; reference pushes back to
``+-(max_angle - width)``. Jacobian: the first two rows of the Euler-rate map
applied to the body angular velocity (no arm columns).
"""

from __future__ import annotations

import math

import numpy as np

from kcl.activation import increasing_bell
from kcl.rotations import euler_rate_matrix
from kcl.tasks.base import GAIN, MAX_RATE, Param, Task, TaskContext, TaskOutput, saturate


class VehicleHorizontalAttitude(Task):
    TYPE = "vehicle_horizontal_attitude"
    KIND = "inequality"
    USES_ARM = False
    PARAMS = {
        "gain": GAIN,
        "max_rate": MAX_RATE,
        "max_angle": Param(0.1, "positive", "largest roll and pitch, rad"),
        "width": Param(0.05, "positive", "transition width, rad"),
    }

    def dim(self) -> int:
        return 2

    def evaluate(self, ctx: TaskContext) -> TaskOutput:
        p = self.params
        eta = ctx.kin.eta
        roll, pitch = float(eta[3]), float(eta[4])
        x = np.array([roll, pitch])
        J = np.zeros((2, self.n))
        J[:, self.l + 3 :] = euler_rate_matrix(roll, pitch)[0:2]
        lim = p["max_angle"] - p["width"]
        a = np.array([increasing_bell(abs(roll), lim, p["max_angle"]), increasing_bell(abs(pitch), lim, p["max_angle"])])
        err = np.array([math.copysign(lim, v) - v if ai > 0.0 else 0.0 for v, ai in zip((roll, pitch), a.tolist())])
        return TaskOutput(x, J, a, saturate(p["gain"] * err, p["max_rate"]), err)
