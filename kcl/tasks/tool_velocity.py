"""Tool velocity (non-reactive, 6 rows): the tool frame moves at a commanded twist.

The operator's Cartesian jog of supervised autonomy: ``Targets.tool_velocity =
[vx vy vz wx wy wz]`` (m/s, rad/s; the linear part is the velocity of the frame's
origin), in world axes (NED) or, with ``in_vehicle_frame``, in vehicle axes
(rotated to the world by the vehicle's attitude). Jacobian: the frame's world
Jacobian ``[linear; angular]``; reference: the twist, scaled down as a whole
(direction kept) until its linear part stays within ``max_rate`` (m/s per axis)
and its angular part within ``max_angular_rate`` (rad/s per axis); activation 1;
value: the commanded twist in world axes; error: zero. Idle without a command.

Placed below the safety tasks of the hierarchy, it gets what they leave: a jog
towards a joint limit, the altitude floor or a singular posture slows down and
stops, whatever the operator asks. With the vehicle DOFs free in the action, the
vehicle moves the tool where the arm alone cannot (coordinated control).
"""

from __future__ import annotations

from kcl.tasks.base import Param, Task
from kcl.tasks.jit import (
    ENV_HAS_TOOL_VELOCITY,
    ENV_TOOL_VELOCITY,
    IDLE_NO_TOOL_VELOCITY,
    RowInputs,
    TaskRows,
    njit,
    twist_into,
)


@njit
def tool_velocity_rows(inp: RowInputs, out: TaskRows) -> int:
    """Row kernel (kcl.tasks.jit). p = [max_rate, max_angular_rate, in_vehicle_frame
    (0/1)]; frames = [controlled frame]."""
    p, frames, Jw, wRv, env = inp.p, inp.frames, inp.Jw, inp.wRv, inp.env
    x, J, a, xdot = out.x, out.J, out.a, out.xdot
    if env[ENV_HAS_TOOL_VELOCITY] == 0.0:
        return IDLE_NO_TOOL_VELOCITY
    for i in range(6):
        x[i] = env[ENV_TOOL_VELOCITY + i]
    if p[2] != 0.0:  # vehicle axes -> world axes
        for block in (0, 3):
            v0, v1, v2 = x[block], x[block + 1], x[block + 2]
            for r in range(3):
                x[block + r] = wRv[r, 0] * v0 + wRv[r, 1] * v1 + wRv[r, 2] * v2
    f = frames[0]
    for i in range(6):
        J[i, :] = Jw[f, i, :]
        a[i] = 1.0
    twist_into(xdot, x, p[0], p[1])
    return 0


class ToolVelocity(Task):
    TYPE = "tool_velocity"
    KIND = "velocity"
    PARAMS = {
        "max_rate": Param(0.1, "positive", "largest reference speed per axis, m/s"),
        "max_angular_rate": Param(0.2, "positive", "largest reference angular rate per axis, rad/s"),
        "in_vehicle_frame": Param(False, "bool", "the command is in vehicle axes (else world axes, NED)"),
        "frame": Param("tool", "frame", "controlled frame"),
    }
    ROW_KERNEL = staticmethod(tool_velocity_rows)

    def dim(self) -> int:
        return 6
