"""Vehicle position and heading (equality, 4 rows: x, y, z in m, yaw in rad, world NED).

Goal: ``Targets.vehicle_goal = [x, y, z, yaw]`` (survey waypoint or station).
Reference ``gain (goal - x)`` (yaw error wrapped to [-pi, pi)), scaled down as
a whole, by one factor, until the position part stays within ``max_rate``
(m/s per axis) and the yaw part within ``max_yaw_rate`` (rad/s): the reference
keeps the error's direction (position and heading converge together), as
every other task's saturation does (:func:`kcl.tasks.base.saturate`).
Jacobian: ``[0, wRv, 0]`` for the position, the yaw row of the Euler-rate map
for the heading. Idle without a goal.
"""

from __future__ import annotations

import numpy as np

from kcl.rotations import euler_rate_matrix, wrap_angle
from kcl.tasks.base import GAIN, Param, Task, TaskContext, TaskOutput


class VehiclePositionHeading(Task):
    TYPE = "vehicle_position_heading"
    USES_ARM = False
    PARAMS = {
        "gain": GAIN,
        "max_rate": Param(0.3, "positive", "largest reference speed per axis, m/s"),
        "max_yaw_rate": Param(0.2, "positive", "largest reference yaw rate, rad/s"),
    }

    def dim(self) -> int:
        return 4

    def evaluate(self, ctx: TaskContext) -> TaskOutput:
        goal = ctx.targets.vehicle_goal
        if goal is None:
            return self.idle("no vehicle_goal")
        p = self.params
        kin = ctx.kin
        eta = kin.eta
        x = np.array([eta[0], eta[1], eta[2], eta[5]])
        err = np.asarray(goal, dtype=float) - x
        err[3] = wrap_angle(err[3])
        J = np.zeros((4, self.n))
        J[0:3, self.l : self.l + 3] = kin.wRv
        J[3, self.l + 3 :] = euler_rate_matrix(eta[3], eta[4])[2]
        xdot = p["gain"] * err
        scale = min(1.0, _room(xdot[0:3], p["max_rate"]), _room(xdot[3:4], p["max_yaw_rate"]))
        return TaskOutput(x, J, np.ones(4), xdot * scale, err)


def _room(x: np.ndarray, limit: float) -> float:
    """Factor (<= 1) that brings every entry of ``x`` within ``limit``; 1 when they already are."""
    peak = float(np.max(np.abs(x)))
    return limit / peak if peak > limit else 1.0
