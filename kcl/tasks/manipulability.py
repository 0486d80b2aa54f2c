"""Arm manipulability (inequality ``mu >= mu_min``, MARIS eq. 14-18).

x = mu(q) = sqrt(det(J_a J_a^T)) of the arm-only Jacobian of ``frame`` (the
tool by default; mixed m / rad units). Activation: decreasing bell over
``[mu_min, mu_min + width]``, reference ``gain (mu_min + width - mu)``.
Jacobian ``[dmu/dq  0_{1x6}]`` (analytic gradient, :mod:`kcl.manipulability`), computed only
while the task is active (``mu < mu_min + width``; zero otherwise, where the
activation is zero too).
"""

from __future__ import annotations

import math

import numpy as np

from kcl.manipulability import manipulability_gradient
from kcl.small_linalg import gram_sqrt_det
from kcl.tasks.base import GAIN, MAX_RATE, Param, Task
from kcl.tasks.jit import RowInputs, TaskRows, lower_bound_row, njit, saturate_into


@njit
def manipulability_rows(inp: RowInputs, out: TaskRows) -> int:
    """Row kernel (kcl.tasks.jit). p = [gain, max_rate, mu_min, width,
    above (l x l, row-major), at_or_below (l x l)] (masks of
    ``UvmsModel.hessian_masks``); frames = [frame]."""
    p, frames, Jw, q = inp.p, inp.frames, inp.Jw, inp.q
    x, J, a, xdot, err = out.x, out.J, out.a, out.xdot, out.err
    l = q.shape[0]
    f = frames[0]
    Ja = np.ascontiguousarray(Jw[f, :, :l])  # arm-only Jacobian, world axes (mu is rotation invariant)
    xbar = p[2] + p[3]
    mu = gram_sqrt_det(Ja)
    x[0] = mu
    if mu >= xbar:  # inactive: the gradient (the costly part) is not needed
        return 0
    if not np.isfinite(Ja).all():  # refused by the solver (NaN activation), never raised here
        x[0] = a[0] = math.nan
        return 0
    above = p[4 : 4 + l * l].reshape((l, l))
    below = p[4 + l * l : 4 + 2 * l * l].reshape((l, l))
    grad = np.empty(l)
    mu = manipulability_gradient(Ja, above, below, grad)
    for i in range(l):
        J[0, i] = grad[i]
    lower_bound_row(mu, p[2], p[3], x, a, err)
    saturate_into(xdot, err, p[0], p[1])
    return 0


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
    ROW_KERNEL = staticmethod(manipulability_rows)

    def kernel_params(self) -> list[float]:
        above, at_or_below = self.model.hessian_masks(self.params["frame"])
        return [*super().kernel_params(), *above.ravel().tolist(), *at_or_below.ravel().tolist()]

    def dim(self) -> int:
        return 1
