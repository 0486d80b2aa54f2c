"""End-effector angular position (equality, 3 rows, world axes, rad).

Error: the rotation vector ``log(R_goal R^T)`` (world axes) from the tool frame
orientation R to the goal's; reference ``gain * error`` saturated to
``max_rate`` (rad/s); Jacobian: angular rows of the tool's world Jacobian (so
the task "value" is an orientation and its rate an angular velocity).
An orientation has no vector form: ``x`` reports the error vector too.
"""

from __future__ import annotations

import numpy as np

from kcl.rotations import so3_log
from kcl.tasks.base import GAIN, Param, Task, TaskContext, TaskOutput, saturate


_ONES3 = np.ones(3)
_ONES3.setflags(write=False)


class ToolOrientation(Task):
    TYPE = "tool_orientation"
    PARAMS = {
        "gain": GAIN,
        "max_rate": Param(0.3, "positive", "largest reference angular rate per axis, rad/s"),
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
        R = kin.pose_world(frame)[:3, :3]
        err = so3_log(np.asarray(goal, dtype=float)[:3, :3] @ R.T)
        xdot = saturate(self.params["gain"] * err, self.params["max_rate"])
        return TaskOutput(err, kin.jacobian_world(frame)[3:6], _ONES3, xdot, err)
