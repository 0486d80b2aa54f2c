"""Vehicle position and heading (equality, 4 rows: x, y, z in m, yaw in rad, world NED).

Goal: ``Targets.vehicle_goal = [x, y, z, yaw]`` (survey waypoint or station).
Reference ``gain (goal - x)`` (yaw error wrapped to [-pi, pi)), scaled down as
a whole, by one factor, until the position part stays within ``max_rate``
(m/s per axis) and the yaw part within ``max_yaw_rate`` (rad/s): the reference
keeps the error's direction (position and heading converge together), as
every other task's saturation does (:func:`kcl.tasks.base.saturate`).
Jacobian: ``[0, wRv, 0]`` for the position, the yaw row of the Euler-rate map
for the heading. Idle without a goal. The row kernel writes the same rows as
:meth:`VehiclePositionHeading.evaluate` (the same operations), so the
controller's compiled vehicle step covers the survey and lift actions.
"""

from __future__ import annotations

import math

import numpy as np

from kcl.rotations import euler_rate_matrix, wrap_angle
from kcl.tasks.base import GAIN, Param, Task, TaskContext, TaskOutput
from kcl.tasks.jit import ENV_HAS_VEHICLE_GOAL, ENV_VEHICLE_GOAL, IDLE_NO_VEHICLE_GOAL, njit


@njit
def vehicle_pose_rows(p, frames, P, Jw, q, eta, wRv, env, x, J, a, xdot, err):
    """Row kernel (kcl.tasks.jit). p = [gain, max_rate, max_yaw_rate]."""
    if env[ENV_HAS_VEHICLE_GOAL] == 0.0:
        return IDLE_NO_VEHICLE_GOAL
    l = q.shape[0]
    x[0], x[1], x[2], x[3] = eta[0], eta[1], eta[2], eta[5]
    for i in range(4):
        err[i] = env[ENV_VEHICLE_GOAL + i] - x[i]
    err[3] = (err[3] + math.pi) % (2.0 * math.pi) - math.pi  # wrap_angle
    for r in range(3):
        for c in range(3):
            J[r, l + c] = wRv[r, c]
    roll, pitch = eta[3], eta[4]
    cp = math.cos(pitch)
    J[3, l + 4] = math.sin(roll) / cp  # yaw row of kcl.rotations.euler_rate_matrix
    J[3, l + 5] = math.cos(roll) / cp
    gain = p[0]
    peak = 0.0
    for i in range(4):
        xdot[i] = gain * err[i]
        a[i] = 1.0
        if i < 3 and abs(xdot[i]) > peak:
            peak = abs(xdot[i])
    scale = 1.0
    if peak > p[1]:
        scale = min(scale, p[1] / peak)
    if abs(xdot[3]) > p[2]:
        scale = min(scale, p[2] / abs(xdot[3]))
    for i in range(4):
        xdot[i] = xdot[i] * scale
    return 0


class VehiclePositionHeading(Task):
    TYPE = "vehicle_position_heading"
    USES_ARM = False
    PARAMS = {
        "gain": GAIN,
        "max_rate": Param(0.3, "positive", "largest reference speed per axis, m/s"),
        "max_yaw_rate": Param(0.2, "positive", "largest reference yaw rate, rad/s"),
    }
    ROW_KERNEL = staticmethod(vehicle_pose_rows)
    KERNEL_ID = 12

    def kernel_params(self) -> list[float]:
        p = self.params
        return [float(p["gain"]), float(p["max_rate"]), float(p["max_yaw_rate"])]

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
