"""Arm velocity minimization (non-reactive, l rows): ``qdot = 0``.

Jacobian ``[I_l 0]``, reference 0, activation 1: keeps the arm still (hold,
lift).
"""

from __future__ import annotations

import numpy as np

from kcl.tasks.base import Task
from kcl.tasks.jit import njit


@njit
def arm_stop_rows(
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
    """Row kernel (kcl.tasks.jit): J = [I_l 0], activation 1; value, reference and
    error stay 0 (the rows arrive zeroed). No parameters, no frames."""
    for i in range(q.shape[0]):
        J[i, i] = 1.0
        a[i] = 1.0
    return 0


class ArmVelocityMinimization(Task):
    TYPE = "arm_velocity_minimization"
    KIND = "velocity"
    USES_VEHICLE = False
    PARAMS = {}
    ROW_KERNEL = staticmethod(arm_stop_rows)

    def dim(self) -> int:
        return self.l
