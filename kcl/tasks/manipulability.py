"""Arm manipulability (inequality ``mu >= mu_min``, MARIS eq. 14-18).

x = mu(q) = sqrt(det(J_a J_a^T)) of the arm-only Jacobian of ``frame`` (the
tool by default; mixed m / rad units). Activation: decreasing bell over
``[mu_min, mu_min + width]``, reference ``gain (mu_min + width - mu)``.
Jacobian ``[dmu/dq  0_{1x6}]`` (analytic gradient, kcl.model), computed only
while the task is active (``mu < mu_min + width``; zero otherwise, where the
activation is zero too).
"""

from __future__ import annotations

import numpy as np

from kcl.activation import decreasing_bell
from kcl.tasks.base import GAIN, MAX_RATE, Param, Task, TaskContext, TaskOutput, saturate


class ArmManipulability(Task):
    TYPE = "arm_manipulability"
    KIND = "inequality"
    USES_VEHICLE = False
    PARAMS = {
        "gain": GAIN,
        "max_rate": MAX_RATE,
        "mu_min": Param(0.01, "positive", "minimum manipulability"),
        "width": Param(0.01, "positive", "transition width of the activation"),
        "frame": Param("tool", "frame", "frame (role or URDF name) whose manipulability is kept up"),
    }

    def dim(self) -> int:
        return 1

    def evaluate(self, ctx: TaskContext) -> TaskOutput:
        p = self.params
        xbar = p["mu_min"] + p["width"]
        mu = ctx.kin.manipulability_value(p["frame"])
        J = np.zeros((1, self.n))
        if mu >= xbar:  # inactive: the gradient (the costly part) is not needed
            return TaskOutput(np.array([mu]), J, np.zeros(1), np.zeros(1), np.zeros(1))
        mu, grad = ctx.kin.manipulability(p["frame"])
        mu = float(mu)
        J[0, : self.l] = grad
        a = decreasing_bell(mu, p["mu_min"], xbar)
        err = np.array([xbar - mu if a > 0.0 else 0.0])
        xdot = saturate(p["gain"] * err, p["max_rate"])
        return TaskOutput(np.array([mu]), J, np.array([a], dtype=float), xdot, err)
