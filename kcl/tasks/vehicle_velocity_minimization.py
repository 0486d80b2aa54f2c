"""Vehicle velocity minimization (non-reactive, 6 rows): ``v = 0``.

Jacobian ``[0_{6 x l} I_6]``, reference 0, activation 1: holds the vehicle still
(station keeping in velocity), e.g. while the arm moves to transport posture.
Value: the vehicle velocity fed to the TPIK (error its opposite).
"""

from __future__ import annotations

import numpy as np

from kcl.tasks.base import Task
from kcl.tasks.jit import ENV_VELOCITY, njit


@njit
def vehicle_stop_rows(
    p: np.ndarray,
    frames: np.ndarray,
    P: np.ndarray,
    Jw: np.ndarray,
    q: np.ndarray,
    eta: np.ndarray,
    wRv: np.ndarray,
    env: np.ndarray,
    x: np.ndarray,
    J: np.ndarray,
    a: np.ndarray,
    xdot: np.ndarray,
    err: np.ndarray,
) -> int:
    """Row kernel (kcl.tasks.jit): J = [0 I_6], activation 1, reference 0; value the
    fed velocity (``env``'s velocity part), error its opposite. No parameters, no frames."""
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
