"""Vehicle velocity (non-reactive, 6 rows): the vehicle moves at a commanded body velocity.

The operator's jog of the vehicle in supervised autonomy: ``Targets.vehicle_velocity
= [u v w p q r]`` (m/s, rad/s, vehicle frame FRD). Jacobian ``[0_{6 x l} I_6]``;
reference: the command, scaled down as a whole (direction kept) until its linear
part stays within ``max_rate`` (m/s per axis) and its angular part within
``max_angular_rate`` (rad/s per axis); activation 1; value: the command; error:
zero. Idle without a command. Below the safety tasks (altitude, attitude,
geofence) it gets what they leave.
"""

from __future__ import annotations

from kcl.tasks.base import Param, Task
from kcl.tasks.jit import (
    ENV_HAS_VEHICLE_VELOCITY,
    ENV_VEHICLE_VELOCITY,
    IDLE_NO_VEHICLE_VELOCITY,
    RowInputs,
    TaskRows,
    njit,
    twist_into,
)


@njit
def vehicle_velocity_rows(inp: RowInputs, out: TaskRows) -> int:
    """Row kernel (kcl.tasks.jit). p = [max_rate, max_angular_rate]."""
    p, q, env = inp.p, inp.q, inp.env
    x, J, a, xdot = out.x, out.J, out.a, out.xdot
    if env[ENV_HAS_VEHICLE_VELOCITY] == 0.0:
        return IDLE_NO_VEHICLE_VELOCITY
    l = q.shape[0]
    for i in range(6):
        x[i] = env[ENV_VEHICLE_VELOCITY + i]
    for i in range(6):
        J[i, l + i] = 1.0
        a[i] = 1.0
    twist_into(xdot, x, p[0], p[1])
    return 0


class VehicleVelocity(Task):
    TYPE = "vehicle_velocity"
    KIND = "velocity"
    USES_ARM = False
    PARAMS = {
        "max_rate": Param(0.2, "positive", "largest reference speed per axis, m/s"),
        "max_angular_rate": Param(0.2, "positive", "largest reference angular rate per axis, rad/s"),
    }
    ROW_KERNEL = staticmethod(vehicle_velocity_rows)

    def dim(self) -> int:
        return 6
