"""Compiled per-step helpers of the simulator's arm, commands and joint readings.

Each is one compiled call per step on the simulator's state arrays, doing the
arithmetic of the numpy expression it stands for in the same order (the
results are bit for bit the same):

* :func:`arm_step`: the drives' first-order lag, joint limits
  (:meth:`sim_backend.arm_sim.ArmJoints.step`);
* :func:`arm_command`: the arm command's checks and clipping (the vehicle's:
  :func:`sim_backend.vehicle_kernel.vehicle_command`);
* :func:`joint_readings`: the arm's readings (:mod:`sim_backend.devices`; the
  vehicle's navigation reading is one ``ndarray.take`` of the backend's ``nav_buffer``);
* the coupling's inputs and terms: :mod:`sim_backend.coupling_kernel`.
"""

from __future__ import annotations

import numpy as np
from numba import njit

#: rows of the arm's state array (:class:`sim_backend.arm_sim.ArmJoints` ``A``): positions (rad),
#: velocities (rad/s), velocity references (rad/s), 1/0 drive healthy, lower and upper limits (rad),
#: the velocities of the previous step and the joint accelerations (rad/s^2, the full vehicle's coupling),
#: the velocity limits (rad/s)
R_Q, R_QDOT, R_CMD, R_HEALTHY, R_LOWER, R_UPPER, R_QDOT_PREV, R_QDDOT, R_VMAX = range(9)
N_ROWS = 9


@njit(cache=True)
def arm_step(h: float, alpha: float, enabled: bool, idle: bool, A: np.ndarray) -> None:
    """Advance the joints ``h`` s in place (the ``R_*`` rows of ``A``: ``q`` rad,
    ``qdot`` rad/s); ``alpha``: the lag's factor for ``h``; ``idle``: the command is all zero."""
    q, qdot, command, healthy, lower, upper = A[R_Q], A[R_QDOT], A[R_CMD], A[R_HEALTHY], A[R_LOWER], A[R_UPPER]
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
def arm_command(qdot: np.ndarray, A: np.ndarray) -> int:
    """Joint velocity references ``qdot`` into the command row of the arm's state ``A``
    (non-finite entries count as zero, clipped to +-``vmax``, its ``R_VMAX`` row).
    Returns bit 0: all finite, bit 1: all zero (idle)."""
    vmax, command = A[R_VMAX], A[R_CMD]
    finite = True
    idle = True
    for j in range(qdot.shape[0]):
        c = qdot[j]
        if not np.isfinite(c):
            c = 0.0
            finite = False
        if c > vmax[j]:
            c = vmax[j]
        if c < -vmax[j]:
            c = -vmax[j]
        command[j] = c
        if c != 0.0:
            idle = False
    return (1 if finite else 0) | (2 if idle else 0)


@njit(cache=True)
def joint_readings(
    A: np.ndarray,
    enabled: bool,
    idle_current: float,
    k_current: float,
    encoder_noise: float,
    current_noise: float,
    buf: np.ndarray,
    i: int,
    out: np.ndarray,
) -> None:
    """Encoder positions, velocities and motor currents of the arm's state ``A`` (its
    ``q`` and ``qdot`` rows) into ``out`` (3 n,): ``q +
    encoder_noise n_j``, ``qdot``, ``idle + k |qdot| + current_noise n_(n+j)`` with the
    standard normals ``buf[i:i + 2 n]`` (as :meth:`sim_backend.devices.SimArm.joint_state`)."""
    q, qdot = A[R_Q], A[R_QDOT]
    n = q.shape[0]
    on = 1.0 if enabled else 0.0
    for j in range(n):
        out[j] = q[j] + encoder_noise * buf[i + j]
        out[n + j] = qdot[j]
        out[2 * n + j] = (idle_current * on + k_current * abs(qdot[j])) + current_noise * buf[i + n + j]
