"""First-order low-pass filter of the vehicle velocity fed back to TPIK 2.

MARIS filtered the measured vehicle velocity (first order, cutoff 50 rad/s)
before the arm compensated it: unfiltered noisy angular rates made the arm
oscillate and excite the vehicle.

Discretisation: exact for an input held constant over each step,
``y += (1 - exp(-w dt)) (x - y)``, so irregular sample times are fine. The
controller's cycle (:mod:`kcl.cycle`) applies the step to :attr:`FirstOrderLowPass.y`
in its compiled call (:func:`lowpass_step`), after checking the sample, and
then tells the filter (:meth:`FirstOrderLowPass.accept`).
"""

from __future__ import annotations

import math

import numpy as np

from kcl.jit import njit

#: what the next sample does (:meth:`FirstOrderLowPass.mode_at`)
NO_CHANGE, START, STEP = 0, 1, 2


@njit
def lowpass_step(y: np.ndarray, x: np.ndarray, k: float) -> None:
    """``y += k (x - y)`` in place, element by element."""
    for i in range(y.shape[0]):
        y[i] += k * (x[i] - y[i])


class FirstOrderLowPass:
    """Vector low-pass ``tau dy/dt = x - y`` with ``tau = 1 / cutoff_rad_s``.

    The first sample initialises the output (no start-up transient); a sample
    not newer than the previous one leaves the output unchanged.
    """

    def __init__(self, cutoff_rad_s: float, size: int):
        if not (cutoff_rad_s > 0 and math.isfinite(cutoff_rad_s)):
            raise ValueError(f"cutoff must be a positive finite rad/s value, got {cutoff_rad_s!r}")
        self.cutoff_rad_s = float(cutoff_rad_s)
        self.size = size
        #: the state (the output), updated in place
        self.y = np.zeros(size)
        #: time of the last accepted sample (s), None before the first
        self.t: float | None = None

    def reset(self) -> None:
        """Forget the state; the next sample restarts the filter."""
        self.t = None
        self.y[:] = 0.0

    @property
    def value(self) -> np.ndarray | None:
        """Current output (copy), or None before the first sample."""
        return None if self.t is None else self.y.copy()

    def mode_at(self, t: float) -> tuple[int, float]:
        """What a sample taken at ``t`` (s) does: ``(START, 0)`` (the first),
        ``(STEP, gain)`` (newer than the last: ``y += gain (x - y)``) or
        ``(NO_CHANGE, 0)``."""
        if self.t is None:
            return START, 0.0
        dt = t - self.t
        if dt > 0.0:
            return STEP, 1.0 - math.exp(-self.cutoff_rad_s * dt)
        return NO_CHANGE, 0.0

    def accept(self, t: float, mode: int) -> None:
        """Record that a sample at ``t`` (s) was applied to :attr:`y` with ``mode``."""
        if mode != NO_CHANGE:
            self.t = float(t)

    def update(self, x: np.ndarray, t: float) -> np.ndarray:
        """Feed sample ``x`` measured at time ``t`` (s); returns the filtered value (copy)."""
        mode, gain = self.mode_at(t)
        x = np.ascontiguousarray(x, dtype=float)
        if mode == START:
            self.y[:] = x
        elif mode == STEP:
            lowpass_step(self.y, x, gain)
        self.accept(t, mode)
        return self.y.copy()
