"""Wall-clock timing of the supervisor loop: per-step work and, in real time,
deadline misses.

A step's *work* is the wall time (s) from its start to the moment it hands
control to ``backend.advance`` (device reads, safety, tree, KCL, commands,
logging): in real time the rest of the base period is spent waiting for the
next tick. :class:`StepTimes` keeps every step's work (8 bytes a step) and
reports percentiles at the end; real backends add their own wake-up figures
(:meth:`hal.drivers.realtime.TickPacer.timing`). These are wall-clock figures:
they depend on the machine and its load, never on the run's inputs, and they
are kept out of the deterministic results (names start with ``wall``).
"""

from __future__ import annotations

from array import array
from typing import Any

import numpy as np


class StepTimes:
    """Work time (s) of every loop step, in order."""

    def __init__(self) -> None:
        self.work = array("d")

    def summary(self, period_s: float) -> dict[str, Any]:
        """``{steps, p50_s, p99_s, p999_s, max_s, over_period}``: percentiles of the
        work per step and how many steps worked longer than ``period_s``."""
        w = np.frombuffer(self.work, dtype=float) if len(self.work) else np.zeros(0)
        if w.size == 0:
            return {"steps": 0, "p50_s": None, "p99_s": None, "p999_s": None, "max_s": None, "over_period": 0}
        p50, p99, p999 = np.percentile(w, (50.0, 99.0, 99.9)).tolist()
        return {"steps": int(w.size), "p50_s": p50, "p99_s": p99, "p999_s": p999, "max_s": float(w.max()),
                "over_period": int(np.count_nonzero(w > period_s))}
