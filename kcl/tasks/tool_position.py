"""End-effector linear position (equality, 3 rows, world NED, m).

x = position of the tool frame origin in the world; goal = origin of
``Targets.tool_goal``; reference ``gain (goal - x)`` saturated to ``max_rate``
(m/s). Jacobian: linear rows of the tool's world Jacobian. Idle without a goal.
"""

from __future__ import annotations

import numpy as np

from kcl.tasks.base import GAIN, Param, Task, TaskContext, TaskOutput, saturate


_ONES3 = np.ones(3)
_ONES3.setflags(write=False)


class ToolPosition(Task):
    TYPE = "tool_position"
    PARAMS = {
        "gain": GAIN,
        "max_rate": Param(0.2, "positive", "largest reference speed per axis, m/s"),
        "frame": Param("tool", "frame", "controlled frame"),
    }

    def dim(self) -> int:
        return 3

    def evaluate(self, ctx: TaskContext) -> TaskOutput:
        goal = ctx.targets.tool_goal
        if goal is None:
            return self.idle("no tool_goal")
        kin = ctx.kin
        frame = self.params["frame"]
        x = kin.position_world(frame)
        err = np.asarray(goal, dtype=float)[:3, 3] - x
        xdot = saturate(self.params["gain"] * err, self.params["max_rate"])
        return TaskOutput(x.copy(), kin.jacobian_world(frame)[0:3], _ONES3, xdot, err)
