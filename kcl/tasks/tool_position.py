"""End-effector linear position (equality, 3 rows, world NED, m).

x = position of the tool frame origin in the world; goal = origin of
``Targets.tool_goal``; reference ``gain (goal - x)`` saturated to ``max_rate``
(m/s). Jacobian: linear rows of the tool's world Jacobian. Idle without a goal.
"""

from __future__ import annotations

from kcl.tasks.base import GAIN, Param, Task
from kcl.tasks.jit import ENV_HAS_TOOL_GOAL, ENV_TOOL_GOAL, IDLE_NO_TOOL_GOAL, RowInputs, TaskRows, njit, saturate_into


@njit
def tool_position_rows(inp: RowInputs, out: TaskRows) -> int:
    """Row kernel (kcl.tasks.jit). p = [gain, max_rate]; frames = [controlled frame]."""
    p, frames, P, Jw, env = inp.p, inp.frames, inp.P, inp.Jw, inp.env
    x, J, a, xdot, err = out.x, out.J, out.a, out.xdot, out.err
    if env[ENV_HAS_TOOL_GOAL] == 0.0:
        return IDLE_NO_TOOL_GOAL
    f = frames[0]
    for i in range(3):
        x[i] = P[f, i, 3]
        err[i] = env[ENV_TOOL_GOAL + 4 * i + 3] - x[i]
        a[i] = 1.0
        J[i, :] = Jw[f, i, :]
    saturate_into(xdot, err, p[0], p[1])
    return 0


class ToolPosition(Task):
    TYPE = "tool_position"
    PARAMS = {
        "gain": GAIN,
        "max_rate": Param(0.2, "positive", "largest reference speed per axis, m/s"),
        "frame": Param("tool", "frame", "controlled frame"),
    }
    ROW_KERNEL = staticmethod(tool_position_rows)

    def dim(self) -> int:
        return 3
