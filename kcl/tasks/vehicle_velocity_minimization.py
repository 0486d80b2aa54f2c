"""Vehicle velocity minimization (non-reactive, 6 rows): ``v = 0``.

Jacobian ``[0_{6 x l} I_6]``, reference 0, activation 1: holds the vehicle still
(station keeping in velocity), e.g. while the arm moves to transport posture.
Value: the vehicle velocity fed to the TPIK (error its opposite).
"""

from __future__ import annotations

from kcl.tasks.base import Task
from kcl.tasks.jit import ENV_VELOCITY, RowInputs, TaskRows, njit


@njit
def vehicle_stop_rows(inp: RowInputs, out: TaskRows) -> int:
    """Row kernel (kcl.tasks.jit): J = [0 I_6], activation 1, reference 0; value the
    fed velocity (``env``'s velocity part), error its opposite. No parameters, no frames."""
    q, env = inp.q, inp.env
    x, J, a, err = out.x, out.J, out.a, out.err
    l = q.shape[0]
    for i in range(6):
        J[i, l + i] = 1.0
        a[i] = 1.0
        v = env[ENV_VELOCITY + i]
        x[i] = v
        err[i] = -v
    return 0


class VehicleVelocityMinimization(Task):
    TYPE = "vehicle_velocity_minimization"
    KIND = "velocity"
    USES_ARM = False
    PARAMS = {}
    ROW_KERNEL = staticmethod(vehicle_stop_rows)

    def dim(self) -> int:
        return 6
