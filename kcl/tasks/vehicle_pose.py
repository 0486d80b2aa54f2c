"""Vehicle position and heading (equality, 4 rows: x, y, z in m, yaw in rad, world NED).

Goal: ``Targets.vehicle_goal = [x, y, z, yaw]`` (survey waypoint or station).
Reference ``gain (goal - x)`` (yaw error wrapped to [-pi, pi)), scaled down as
a whole, by one factor, until the position part stays within ``max_rate``
(m/s per axis) and the yaw part within ``max_yaw_rate`` (rad/s): the reference
keeps the error's direction (position and heading converge together), as
every other task's saturation does (:func:`kcl.tasks.jit.saturate_into`).
Jacobian: ``[0, wRv, 0]`` for the position, the yaw row of the Euler-rate map
for the heading. Idle without a goal.
"""

from __future__ import annotations

import math

from kcl.tasks.base import GAIN, Param, Task
from kcl.tasks.jit import ENV_HAS_VEHICLE_GOAL, ENV_VEHICLE_GOAL, IDLE_NO_VEHICLE_GOAL, RowInputs, TaskRows, njit


@njit
def vehicle_pose_rows(inp: RowInputs, out: TaskRows) -> int:
    """Row kernel (kcl.tasks.jit). p = [gain, max_rate, max_yaw_rate]."""
    p, q, eta, wRv, env = inp.p, inp.q, inp.eta, inp.wRv, inp.env
    x, J, a, xdot, err = out.x, out.J, out.a, out.xdot, out.err
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

    def dim(self) -> int:
        return 4
