"""Tool clearance above the bottom (inequality ``clearance >= min_clearance``).

x = the height (m) of the controlled frame (the tool) above the bottom: the
bottom's depth, measured as the vehicle's depth plus its altitude (the DVL's),
minus the frame's world depth, ``(eta_z + altitude) - p_z``. Over a flat bottom
the bottom's depth does not change as the vehicle moves, so the rate is minus
the frame's world-down velocity: ``J = -e_z^T Jw`` (the linear z row of the
frame's world Jacobian, arm and vehicle columns). Activation: decreasing bell
over ``[min_clearance, min_clearance + width]``, reference ``gain (xbar - x)``
towards ``xbar = min_clearance + width``, saturated to ``max_rate`` (m/s). Idle
(and noted) without an altitude measurement.

It keeps an operator's jog from driving the tool into the bottom: the vehicle
altitude task keeps the hull up, this one the end of the arm.
"""

from __future__ import annotations

from kcl.tasks.base import GAIN, Param, Task
from kcl.tasks.jit import ENV_ALTITUDE, ENV_HAS_ALTITUDE, IDLE_NO_ALTITUDE, RowInputs, TaskRows, lower_bound_row, njit


@njit
def tool_clearance_rows(inp: RowInputs, out: TaskRows) -> int:
    """Row kernel (kcl.tasks.jit). p = [gain, max_rate, min_clearance, width]; frames = [controlled frame]."""
    p, frames, P, Jw, eta, env = inp.p, inp.frames, inp.P, inp.Jw, inp.eta, inp.env
    x, J, a, xdot, err = out.x, out.J, out.a, out.xdot, out.err
    if env[ENV_HAS_ALTITUDE] == 0.0:
        return IDLE_NO_ALTITUDE
    f = frames[0]
    clearance = eta[2] + env[ENV_ALTITUDE] - P[f, 2, 3]
    J[0, :] = -Jw[f, 2, :]
    lower_bound_row(clearance, p[2], p[3], x, a, err)
    xdot[0] = min(max(p[0] * err[0], -p[1]), p[1])
    return 0


class ToolClearance(Task):
    TYPE = "tool_clearance"
    KIND = "inequality"
    PARAMS = {
        "gain": GAIN,
        "max_rate": Param(0.1, "positive", "largest reference vertical speed, m/s"),
        "min_clearance": Param(0.15, "positive", "least height of the frame above the bottom, m"),
        "width": Param(0.1, "positive", "transition width, m"),
        "frame": Param("tool", "frame", "controlled frame"),
    }
    ROW_KERNEL = staticmethod(tool_clearance_rows)

    def dim(self) -> int:
        return 1
