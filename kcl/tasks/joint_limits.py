"""Arm joint limits (inequality, one row per joint).

x = q (rad). Each joint must stay in ``[lower + margin, upper - margin]`` (URDF
limits shrunk by ``margin``). Activation: decreasing bell over
``[lo, lo + width]`` plus increasing bell over ``[hi - width, hi]``; the reactive
reference ``gain (xbar - q)`` pushes back to ``lo + width`` or ``hi - width``.
Jacobian ``[I_l 0]``.
"""

from __future__ import annotations

import numpy as np

from kcl.activation import band_activation
from kcl.tasks.base import GAIN, MAX_RATE, Param, Task
from kcl.tasks.jit import RowInputs, TaskRows, njit, saturate_into


@njit
def joint_limits_rows(inp: RowInputs, out: TaskRows) -> int:
    """Row kernel (kcl.tasks.jit). p = [gain, max_rate, width, lo (l), hi (l)]."""
    p, q = inp.p, inp.q
    x, J, a, xdot, err = out.x, out.J, out.a, out.xdot, out.err
    l = q.shape[0]
    w = p[2]
    for i in range(l):
        qi = q[i]
        x[i] = qi
        J[i, i] = 1.0
        a[i], xbar = band_activation(qi, p[3 + i], p[3 + l + i], w)
        err[i] = xbar - qi if a[i] > 0.0 else 0.0
    saturate_into(xdot, err, p[0], p[1])
    return 0


class ArmJointLimits(Task):
    TYPE = "arm_joint_limits"
    KIND = "inequality"
    USES_VEHICLE = False
    PARAMS = {
        "gain": GAIN,
        "max_rate": MAX_RATE,
        "margin": Param(0.05, "nonneg", "safety margin inside the URDF limits, rad"),
        "width": Param(0.2, "positive", "transition width of the activation, rad"),
    }
    ROW_KERNEL = staticmethod(joint_limits_rows)

    def setup(self) -> None:
        p = self.params
        m = self.model
        self.lo = m.joint_lower + p["margin"]
        self.hi = m.joint_upper - p["margin"]
        if np.any(self.hi - self.lo <= 2 * p["width"]):
            raise ValueError("margin and width leave no free range for some joint")

    def kernel_params(self) -> list[float]:
        p = self.params
        return [
            float(p["gain"]),
            float(p["max_rate"]),
            float(p["width"]),
            *self.lo.tolist(),
            *self.hi.tolist(),
        ]

    def dim(self) -> int:
        return self.l
