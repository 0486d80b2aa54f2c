"""Arm preferred shape / posture (equality on selected joints, rad).

x = the joints listed with a value in ``posture`` (one entry per arm joint,
``null`` = free); reference ``gain (posture - q)``, saturated to ``max_rate``
(rad/s). Used for the grasp action's preferred shape and, with other postures,
for the folded (survey) and transport postures. Jacobian: rows of ``[I_l 0]``.
"""

from __future__ import annotations

import numpy as np

from kcl.tasks.base import GAIN, MAX_RATE, Param, Task
from kcl.tasks.jit import RowInputs, TaskRows, njit, saturate_into


@njit
def preferred_shape_rows(inp: RowInputs, out: TaskRows) -> int:
    """Row kernel (kcl.tasks.jit). p = [gain, max_rate, k, joint indices (k), angles (k)]."""
    p, q = inp.p, inp.q
    x, J, a, xdot, err = out.x, out.J, out.a, out.xdot, out.err
    k = int(p[2])
    for r in range(k):
        j = int(p[3 + r])
        x[r] = q[j]
        err[r] = p[3 + k + r] - q[j]
        a[r] = 1.0
        J[r, j] = 1.0
    saturate_into(xdot, err, p[0], p[1])
    return 0


class ArmPreferredShape(Task):
    TYPE = "arm_preferred_shape"
    USES_VEHICLE = False
    PARAMS = {
        "gain": GAIN,
        "max_rate": MAX_RATE,
        "posture": Param(None, "posture", "preferred angle of each joint (rad), null = free"),
    }
    ROW_KERNEL = staticmethod(preferred_shape_rows)

    def setup(self) -> None:
        posture = self.params["posture"]
        if posture is None:
            raise ValueError("posture is required")
        if len(posture) != self.l:
            raise ValueError(f"posture needs {self.l} entries (one per joint), got {len(posture)}")
        self.index = np.array([i for i, v in enumerate(posture) if v is not None], dtype=int)
        if self.index.size == 0:
            raise ValueError("posture leaves every joint free")
        self.target_angles = np.array([posture[i] for i in self.index], dtype=float)
        m = self.model
        if np.any(self.target_angles < m.joint_lower[self.index]) or np.any(
            self.target_angles > m.joint_upper[self.index]
        ):
            raise ValueError("posture outside the joint limits")

    def kernel_params(self) -> list[float]:
        p = self.params
        return [
            float(p["gain"]),
            float(p["max_rate"]),
            float(self.index.size),
            *map(float, self.index),
            *self.target_angles.tolist(),
        ]

    def dim(self) -> int:
        return int(self.index.size)
