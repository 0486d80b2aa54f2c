"""Vehicle altitude above the bottom (inequality ``altitude >= min_altitude``).

x = measured altitude (m, from the DVL, ``TaskContext.altitude``); over a flat
bottom its rate is minus the world-down velocity of the vehicle:
``J = -[0_l, e_z^T wRv, 0_3]``. Activation: decreasing bell over
``[min_altitude, min_altitude + width]``. Idle (and noted) without a measurement.
"""

from __future__ import annotations

from kcl.tasks.base import GAIN, Param, Task
from kcl.tasks.jit import ENV_ALTITUDE, ENV_HAS_ALTITUDE, IDLE_NO_ALTITUDE, RowInputs, TaskRows, lower_bound_row, njit


@njit
def altitude_rows(inp: RowInputs, out: TaskRows) -> int:
    """Row kernel (kcl.tasks.jit). p = [gain, max_rate, min_altitude, width]."""
    p, q, wRv, env = inp.p, inp.q, inp.wRv, inp.env
    x, J, a, xdot, err = out.x, out.J, out.a, out.xdot, out.err
    if env[ENV_HAS_ALTITUDE] == 0.0:
        return IDLE_NO_ALTITUDE
    l = q.shape[0]
    alt = env[ENV_ALTITUDE]
    for k in range(3):
        J[0, l + k] = -wRv[2, k]
    lower_bound_row(alt, p[2], p[3], x, a, err)
    xdot[0] = min(max(p[0] * err[0], -p[1]), p[1])
    return 0


class VehicleAltitude(Task):
    TYPE = "vehicle_altitude"
    KIND = "inequality"
    USES_ARM = False
    PARAMS = {
        "gain": GAIN,
        "max_rate": Param(0.2, "positive", "largest reference vertical speed, m/s"),
        "min_altitude": Param(1.0, "positive", "minimum altitude, m"),
        "width": Param(0.3, "positive", "transition width, m"),
    }
    ROW_KERNEL = staticmethod(altitude_rows)

    def dim(self) -> int:
        return 1
