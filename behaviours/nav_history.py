"""A short history of vehicle poses, to place a detection at its image time.

Vision results arrive late (MARIS: ~10 Hz processing plus transport), while
the vehicle keeps moving. :class:`NavHistory` keeps the last few navigation
states a leaf has seen (one per tick) and returns the vehicle pose at any
past time by linear interpolation (position, and each Euler angle along the
shortest way). Outside the stored span, or between two samples further
apart than ``max_gap_s``, it returns the nearest stored pose.
Pure data structure: no clock, no devices.
"""

from __future__ import annotations

import math
from collections import deque
from typing import NamedTuple

import numpy as np

from hal.interfaces import NavigationState
from kcl.rotations import wrap_angle


class PoseSample(NamedTuple):
    """The vehicle pose ``eta`` (world NED, m / rad) at time ``t`` (s)."""

    t: float
    eta: np.ndarray


class NavHistory:
    """Poses ``eta = [x y z roll pitch yaw]`` (world NED, m / rad) by time (s)."""

    def __init__(self, span_s: float = 2.0, max_len: int = 256, max_gap_s: float = 0.5) -> None:
        self.span_s = float(span_s)
        self.max_gap_s = float(max_gap_s)
        self._items: deque[PoseSample] = deque(maxlen=max_len)

    def __len__(self) -> int:
        return len(self._items)

    def add(self, nav: NavigationState) -> None:
        """Record ``nav`` (ignored if not newer than the last one, or not finite)."""
        t = nav.t
        if not math.isfinite(t) or (self._items and t <= self._items[-1].t):
            return
        values = np.asarray(nav.position, float)[:3].tolist() + np.asarray(nav.attitude, float)[:3].tolist()
        if not -math.inf < sum(values) < math.inf and not all(map(math.isfinite, values)):
            return
        self._items.append(PoseSample(float(t), np.array(values)))
        while self._items and self._items[-1].t - self._items[0].t > self.span_s and len(self._items) > 2:
            self._items.popleft()

    def eta_at(self, t: float) -> np.ndarray | None:
        """Interpolated pose at ``t`` (s); nearest stored pose outside the span; None if empty."""
        if not self._items:
            return None
        items = self._items
        if t <= items[0].t:
            return items[0].eta.copy()
        if t >= items[-1].t:
            return items[-1].eta.copy()
        times = [it.t for it in items]
        k = int(np.searchsorted(times, t))
        (t0, e0), (t1, e1) = items[k - 1], items[k]
        if t1 - t0 > self.max_gap_s:  # no motion information in between: nearest sample
            return (e0 if t - t0 <= t1 - t else e1).copy()
        w = (t - t0) / (t1 - t0)
        out = e0 + w * (e1 - e0)
        out[3:] = e0[3:] + w * wrap_angle(e1[3:] - e0[3:])
        return out
