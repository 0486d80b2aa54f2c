"""First-order low-pass filter for the vehicle velocity fed back to TPIK 2.

MARIS filtered the measured vehicle velocity (first order, cutoff 50 rad/s)
before the arm compensated it: unfiltered noisy angular rates made the arm
oscillate and excite the vehicle.

Discretisation: exact for an input held constant over each step,
``y += (1 - exp(-w dt)) (x - y)``, so irregular sample times are fine.
"""

from __future__ import annotations

import math

import numpy as np

from kcl.cycle import no_compile
from kcl.tasks.jit import njit


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
        self._y = np.zeros(size)
        self._t: float | None = None

    def reset(self) -> None:
        """Forget the state; the next sample restarts the filter."""
        self._t = None
        self._y[:] = 0.0

    @property
    def value(self) -> np.ndarray | None:
        """Current output (copy), or None before the first sample."""
        return None if self._t is None else self._y.copy()

    def feed(self, x: np.ndarray, t: float) -> None:
        """:meth:`update` without returning the value (no copy): the same state
        change, by one compiled call when ``x`` is a writable contiguous float64 array."""
        y_t = self._t
        if y_t is None:
            self._y[:] = x
            self._t = float(t)
            return
        dt = float(t) - y_t
        if dt > 0.0:
            k = 1.0 - math.exp(-self.cutoff_rad_s * dt)
            try:
                _lowpass_step(self._y, x, k)
            except TypeError:  # another kind of array (list, read-only, strided...)
                self._y += k * (np.asarray(x, dtype=float) - self._y)
            self._t = float(t)

    def update(self, x: np.ndarray, t: float) -> np.ndarray:
        """Feed sample ``x`` measured at time ``t`` (s); returns the filtered value (copy)."""
        x = np.asarray(x, dtype=float)
        if self._t is None:
            self._y[:] = x
            self._t = float(t)
        else:
            dt = float(t) - self._t
            if dt > 0.0:
                self._y += (1.0 - math.exp(-self.cutoff_rad_s * dt)) * (x - self._y)
                self._t = float(t)
        return self._y.copy()


@njit
def _lowpass_step(y: np.ndarray, x: np.ndarray, k: float) -> None:
    """``y += k (x - y)`` in place, element by element (the same operations as numpy's)."""
    for i in range(y.shape[0]):
        y[i] += k * (x[i] - y[i])


_lowpass_step(np.zeros(1), np.zeros(1), 0.5)  # load (first time: compile) now, not in a control cycle
no_compile(_lowpass_step)
