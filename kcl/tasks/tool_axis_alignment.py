"""Tool axis alignment (equality, 1 row, rad): the tool frame's x axis along the
goal's x axis, as lines.

What a gripper that closes on a cylinder needs of the grasp frame's orientation:
its closing axis (the tool's x, this project's convention) along the cylinder's
axis (the goal's x); the rotation about that axis, i.e. the approach direction
around the cylinder, is left free. A four-joint arm (Reach Alpha 5) holds the
tool position and this alignment where it cannot hold the whole orientation.

x = rho, the angle (rad, in [0, pi/2]) between the tool's x axis ``a`` and the
goal's x axis ``g`` (world), taking ``-g`` when it is the closer one (a cylinder
has no direction). With ``n = (a x g) / |a x g|``, ``rho_dot = -n . w`` for the
frame's angular velocity ``w``: Jacobian ``-n^T`` times the angular rows of the
frame's world Jacobian, set to zero at ``rho < 1e-9`` (``n`` undefined; the task
is met there). Reference ``gain (0 - rho)`` saturated to ``max_rate`` (rad/s),
error ``-rho``, activation 1. Goal: ``Targets.tool_goal``; idle without one.
"""

from __future__ import annotations

import math

from kcl.tasks.base import GAIN, Param, Task
from kcl.tasks.jit import ENV_HAS_TOOL_GOAL, ENV_TOOL_GOAL, IDLE_NO_TOOL_GOAL, RowInputs, TaskRows, njit, saturate_into


@njit
def tool_axis_alignment_rows(inp: RowInputs, out: TaskRows) -> int:
    """Row kernel (kcl.tasks.jit). p = [gain, max_rate]; frames = [controlled frame]."""
    p, frames, P, Jw, env = inp.p, inp.frames, inp.P, inp.Jw, inp.env
    x, J, a, xdot, err = out.x, out.J, out.a, out.xdot, out.err
    if env[ENV_HAS_TOOL_GOAL] == 0.0:
        return IDLE_NO_TOOL_GOAL
    f = frames[0]
    a0, a1, a2 = P[f, 0, 0], P[f, 1, 0], P[f, 2, 0]
    g0, g1, g2 = env[ENV_TOOL_GOAL], env[ENV_TOOL_GOAL + 4], env[ENV_TOOL_GOAL + 8]
    gn = math.sqrt(g0 * g0 + g1 * g1 + g2 * g2)
    g0, g1, g2 = g0 / gn, g1 / gn, g2 / gn
    d = a0 * g0 + a1 * g1 + a2 * g2
    if d < 0.0:  # the line's other direction is the closer one
        g0, g1, g2, d = -g0, -g1, -g2, -d
    c0, c1, c2 = a1 * g2 - a2 * g1, a2 * g0 - a0 * g2, a0 * g1 - a1 * g0
    s = math.sqrt(c0 * c0 + c1 * c1 + c2 * c2)
    rho = math.atan2(s, d)
    x[0] = rho
    err[0] = -rho
    a[0] = 1.0
    if rho >= 1e-9:
        n0, n1, n2 = c0 / s, c1 / s, c2 / s
        for j in range(J.shape[1]):
            J[0, j] = -(n0 * Jw[f, 3, j] + n1 * Jw[f, 4, j] + n2 * Jw[f, 5, j])
    saturate_into(xdot, err, p[0], p[1])
    return 0


class ToolAxisAlignment(Task):
    TYPE = "tool_axis_alignment"
    PARAMS = {
        "gain": GAIN,
        "max_rate": Param(0.3, "positive", "largest reference angular rate, rad/s"),
        "frame": Param("tool", "frame", "controlled frame"),
    }
    ROW_KERNEL = staticmethod(tool_axis_alignment_rows)

    def dim(self) -> int:
        return 1
