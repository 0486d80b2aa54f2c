"""Arm joints: velocity references tracked with a first-order lag, limits enforced.

Each drive follows its velocity reference (rad/s) with ``arm.time_constant_s``,
clipped to the joint's velocity limit; positions stop at the joint limits (the
drive's software limit: velocity into a limit is cut to zero). A disabled or
faulted drive stops at once and holds (non-backdrivable gears / brakes). Motor
current is modelled as ``idle + k |qdot|`` (A), enough for logs and monitors.
"""

from __future__ import annotations

import math

import numpy as np

from .step_kernel import N_ROWS, R_CMD, R_HEALTHY, R_LOWER, R_Q, R_QDOT, R_UPPER, R_VMAX, arm_command, arm_step


class ArmJoints:
    """Joint state ``q`` (rad), ``qdot`` (rad/s) and its drives (no randomness here)."""

    def __init__(self, params: dict, lower: np.ndarray, upper: np.ndarray, vmax: np.ndarray, q0: np.ndarray):
        n = len(lower)
        #: one array (``R_*`` rows, one column per joint) for the compiled step; the
        #: attributes are views into it, updated in place
        self.A = A = np.zeros((N_ROWS, n))
        self.lower, self.upper, self.vmax = A[R_LOWER], A[R_UPPER], A[R_VMAX]
        self.lower[:] = lower
        self.upper[:] = upper
        self.vmax[:] = vmax
        self.tau = float(params["arm.time_constant_s"])
        self.idle_current = float(params["arm.idle_current_a"])
        self.k_current = float(params["arm.current_per_rad_s"])
        self.q, self.qdot, self.command = A[R_Q], A[R_QDOT], A[R_CMD]
        self.q[:] = np.clip(np.asarray(q0, dtype=float), self.lower, self.upper)
        self.enabled = False
        self.faults: dict[int, str] = {}
        self._n = n
        self._shape = (n,)
        self._healthy = A[R_HEALTHY]
        self._healthy[:] = 1.0
        self._h = -1.0
        self._alpha = 1.0
        self._idle = True  # zero command and zero velocity: nothing to integrate

    @property
    def n(self) -> int:
        """Number of joints."""
        return self._n

    def set_command(self, qdot: np.ndarray) -> bool:
        """Velocity references (rad/s); non-finite entries count as zero. ``command``
        is updated in place. Returns whether ``qdot`` was all finite."""
        if type(qdot) is not np.ndarray or qdot.dtype != np.float64:
            qdot = np.asarray(qdot, dtype=float)
        if qdot.shape != self._shape:
            qdot = qdot.reshape(self._n)
        flags = arm_command(qdot, self.A)
        self._idle = flags >= 2
        return bool(flags & 1)

    def fault(self, joint: int, reason: str) -> None:
        """Put drive ``joint`` in fault: it stops and ignores references."""
        self.faults[joint] = reason
        self._healthy[joint] = 0.0
        self.qdot[joint] = 0.0

    def step(self, h: float) -> None:
        """Advance ``h`` seconds (compiled: :func:`sim_backend.step_kernel.arm_step`)."""
        arm_step(h, self.lag(h), self.enabled, self._idle, self.A)

    def lag(self, h: float) -> float:
        """The drives' first-order lag factor for a step of ``h`` s."""
        if h != self._h:
            self._h = h
            self._alpha = 1.0 - math.exp(-h / self.tau) if self.tau > 0.0 else 1.0
        return self._alpha

    @property
    def idle(self) -> bool:
        """Zero command (as last set): with zero velocity, nothing to integrate."""
        return self._idle

    def currents(self) -> np.ndarray:
        """Motor currents (A) without noise."""
        return self.idle_current * (1.0 if self.enabled else 0.0) + self.k_current * np.abs(self.qdot)
