"""Compiled per-step helpers of the simulator's arm and of the full vehicle's coupling inputs.

Each replaces a few numpy calls that ran every 10 ms step with one compiled
call on the same arrays, doing the same arithmetic in the same order (the
results are bit for bit those of the numpy code they replace):

* :func:`arm_step`: the drives' first-order lag, joint limits
  (:meth:`sim_backend.arm_sim.ArmJoints.step`);
* :func:`coupling_inputs`: the joint accelerations (finite difference of the
  velocities) and Pinocchio's configuration, velocity and acceleration vectors
  for :class:`sim_backend.coupling.ArmCoupling`
  (:meth:`sim_backend.full_vehicle.FullVehicle.step`).
"""

from __future__ import annotations

import numpy as np
from numba import njit


@njit(cache=True)
def arm_step(h: float, alpha: float, enabled: bool, idle: bool, q: np.ndarray, qdot: np.ndarray, command: np.ndarray,
             healthy: np.ndarray, lower: np.ndarray, upper: np.ndarray) -> None:
    """Advance the joints ``h`` s in place (``q`` rad, ``qdot`` rad/s); ``alpha``: the
    lag's factor for ``h``; ``idle``: the command is all zero."""
    n = q.shape[0]
    if idle:
        moving = False
        big = 0.0
        for j in range(n):
            if qdot[j] != 0.0:
                moving = True
            a = abs(qdot[j])
            if a > big:
                big = a
        if not moving:
            return
        if big < 1e-12:  # the lag has died out
            for j in range(n):
                qdot[j] = 0.0
            return
    if enabled:
        for j in range(n):
            target = command[j] * healthy[j]
            qdot[j] += (target - qdot[j]) * alpha
            qdot[j] *= healthy[j]
    else:
        for j in range(n):
            qdot[j] = 0.0
    for j in range(n):
        q[j] += qdot[j] * h
    for j in range(n):
        if q[j] < lower[j]:
            q[j] = lower[j]
            qdot[j] = 0.0
        elif q[j] > upper[j]:
            q[j] = upper[j]
            qdot[j] = 0.0


@njit(cache=True)
def coupling_inputs(h: float, q: np.ndarray, qdot: np.ndarray, qdot_prev: np.ndarray, qddot: np.ndarray, nu: np.ndarray,
                    pin_q: np.ndarray, pin_v: np.ndarray, pin_a: np.ndarray) -> bool:
    """``qddot = (qdot - qdot_prev) / h`` (as ``* (1 / h)``), then ``qdot_prev = qdot``;
    Pinocchio's free-flyer vectors: ``pin_q[7:] = q``, ``pin_v = [nu; qdot]``,
    ``pin_a[6:] = qddot``. Returns whether any joint moves (``qdot`` not all zero)."""
    inv_h = 1.0 / h
    moved = False
    for j in range(q.shape[0]):
        d = qdot[j] - qdot_prev[j]
        d *= inv_h
        qddot[j] = d
        qdot_prev[j] = qdot[j]
        pin_a[6 + j] = d
        pin_v[6 + j] = qdot[j]
        if qdot[j] != 0.0:
            moved = True
    for i in range(6):
        pin_v[i] = nu[i]
    for j in range(q.shape[0]):  # unchanged while no joint moves
        pin_q[7 + j] = q[j]
    return moved
