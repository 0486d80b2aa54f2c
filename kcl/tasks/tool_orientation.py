"""End-effector angular position (equality, 3 rows, world axes, rad).

Error: the rotation vector ``log(R_goal R^T)`` (world axes) from the tool frame
orientation R to the goal's; reference ``gain * error`` saturated to
``max_rate`` (rad/s); Jacobian: angular rows of the tool's world Jacobian (so
the task "value" is an orientation and its rate an angular velocity).
An orientation has no vector form: ``x`` reports the error vector too.
"""

from __future__ import annotations

import math

import numpy as np

from kcl.tasks.base import GAIN, Param, Task
from kcl.tasks.jit import ENV_HAS_TOOL_GOAL, ENV_TOOL_GOAL, IDLE_NO_TOOL_GOAL, RowInputs, TaskRows, njit, saturate_into


@njit
def so3_log_into(R: np.ndarray, out: np.ndarray) -> None:
    """Rotation vector (rad) of the 3x3 rotation ``R`` into ``out`` (3,), angle in
    [0, pi]; same branches as :func:`kcl.rotations.so3_log`."""
    c = 0.5 * (R[0, 0] + R[1, 1] + R[2, 2] - 1.0)
    c = min(1.0, max(-1.0, c))
    theta = math.acos(c)
    v0, v1, v2 = R[2, 1] - R[1, 2], R[0, 2] - R[2, 0], R[1, 0] - R[0, 1]
    if theta < 1e-6:
        out[0], out[1], out[2] = 0.5 * v0, 0.5 * v1, 0.5 * v2
    elif math.pi - theta < 1e-4:
        # near pi: axis from the symmetric part B = (R + I) / 2, sign fixed by v
        k = 0
        for i in range(1, 3):
            if 0.5 * (R[i, i] + 1.0) > 0.5 * (R[k, k] + 1.0):
                k = i
        scale = 1.0 / math.sqrt(max(0.5 * (R[k, k] + 1.0), 1e-300))
        ax = [0.5 * (R[i, k] + (1.0 if i == k else 0.0)) * scale for i in range(3)]
        if ax[0] * v0 + ax[1] * v1 + ax[2] * v2 < 0:
            ax = [-ax[0], -ax[1], -ax[2]]
        norm = math.sqrt(ax[0] * ax[0] + ax[1] * ax[1] + ax[2] * ax[2])
        for i in range(3):
            out[i] = theta * ax[i] / norm
    else:
        f = theta / (2.0 * math.sin(theta))
        out[0], out[1], out[2] = f * v0, f * v1, f * v2


@njit
def tool_orientation_rows(inp: RowInputs, out: TaskRows) -> int:
    """Row kernel (kcl.tasks.jit). p = [gain, max_rate]; frames = [controlled frame]."""
    p, frames, P, Jw, env = inp.p, inp.frames, inp.P, inp.Jw, inp.env
    x, J, a, xdot, err = out.x, out.J, out.a, out.xdot, out.err
    if env[ENV_HAS_TOOL_GOAL] == 0.0:
        return IDLE_NO_TOOL_GOAL
    f = frames[0]
    M = np.empty((3, 3))  # R_goal R^T
    for i in range(3):
        for j in range(3):
            acc = 0.0
            for k in range(3):
                acc += env[ENV_TOOL_GOAL + 4 * i + k] * P[f, j, k]
            M[i, j] = acc
    so3_log_into(M, err)
    for i in range(3):
        x[i] = err[i]
        a[i] = 1.0
        J[i, :] = Jw[f, 3 + i, :]
    saturate_into(xdot, err, p[0], p[1])
    return 0


class ToolOrientation(Task):
    TYPE = "tool_orientation"
    PARAMS = {
        "gain": GAIN,
        "max_rate": Param(0.3, "positive", "largest reference angular rate per axis, rad/s"),
        "frame": Param("tool", "frame", "controlled frame"),
    }
    ROW_KERNEL = staticmethod(tool_orientation_rows)

    def dim(self) -> int:
        return 3
