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
        # rows 0-1 of kcl.rotations.euler_rate_matrix, written out (arm rate)
        sr, cr, tp = math.sin(roll), math.cos(roll), math.tan(pitch)
        J = np.zeros((2, self.n))
        c = self.l + 3
        J[0, c : c + 3] = (1.0, sr * tp, cr * tp)
        J[1, c + 1 : c + 3] = (cr, -sr)
        top = p["max_angle"]
        lim = top - p["width"]
        a_roll = increasing_bell(abs(roll), lim, top)
        a_pitch = increasing_bell(abs(pitch), lim, top)
        e_roll = math.copysign(lim, roll) - roll if a_roll > 0.0 else 0.0
        e_pitch = math.copysign(lim, pitch) - pitch if a_pitch > 0.0 else 0.0
        err = np.array([e_roll, e_pitch])
        return TaskOutput(np.array([roll, pitch]), J, np.array([a_roll, a_pitch]), saturate(p["gain"] * err, p["max_rate"]), err)
