"""An operator input fed by other code: the Foxglove live view, the terminal's keyboard.

The live server (``mission.logs.live``) and the key reader
(``mission.runtime.operator``) sit above the HAL, which never imports them:
they push what the operator sends into a :class:`PushedInput` (from their own
threads), and the supervisor reads it like any device (``latest()``, recorded
and replayed with the others).

Time: a message is stamped on arrival with the backend clock. When it carries
the time it was sent (a ``header.stamp``) and the input knows the clock such
stamps are in (``stamp_clock``), the link's delay, ``stamp_clock() - sent``, is
taken off: the command's ``t`` is when the operator gave it, so a reader can
drop commands that are too old. On a vehicle the stamp clock is the wall clock
(Foxglove stamps with the browser's clock: keep the operator's computer and the
vehicle's synchronised); in a simulation it is the simulated clock, the time
the live server publishes to its clients (a client following it stamps in it).
A stamp from the future (clocks apart, or a wall-clock stamp in a simulation)
counts as no delay and is counted in the health's ``future_stamps``.

The input has no enabling switch (``deadman`` is True): a reader's dead-man is
the age of its commands. The Foxglove Teleop panel repeats its twist at its
publish rate while a direction is held and stops sending when it is released.
"""

from __future__ import annotations

import threading
from collections.abc import Callable
from typing import Any

import numpy as np

from hal.interfaces import Health, HealthState, OperatorInput, OperatorSample, Stamped


class PushedInput(OperatorInput):
    """An operator input fed by :meth:`push_velocity`, :meth:`push_pose`,
    :meth:`push_point`, :meth:`push_image_point` and :meth:`press` (thread-safe).

    ``clock``: the backend's; ``stamp_clock``: the clock of the senders' stamps (s), or
    None to date every command on arrival."""

    def __init__(self, name: str, clock: Callable[[], float], stamp_clock: Callable[[], float] | None = None) -> None:
        self.name = name
        self._now = clock
        self._stamp_clock = stamp_clock
        self._lock = threading.Lock()
        self._t: float | None = None
        self._velocity: Stamped | None = None
        self._pose: Stamped | None = None
        self._point: Stamped | None = None
        self._image_point: Stamped | None = None
        self._presses: dict[str, int] = {}
        self._sample: OperatorSample | None = None
        self._links = 0
        self._link_note = "no sender connected"
        self._received = 0
        self._future = 0
        self._last_delay: float | None = None

    # ------------------------------------------------------------------ senders
    def link(self, up: bool, who: str = "") -> None:
        """A sender connected (``up``) or went away (``who``: its name, for the health)."""
        with self._lock:
            self._links = max(0, self._links + (1 if up else -1))
            self._link_note = f"{who} {'connected' if up else 'disconnected'}".strip()

    def push_velocity(self, values: Any, *, sent: float | None = None) -> None:
        """A velocity command (6,) ``[vx vy vz wx wy wz]`` (m/s, rad/s); ``sent``: its stamp (s, ``stamp_clock``)."""
        v = _vector(values, 6, "velocity")
        with self._lock:
            self._velocity = Stamped(self._stamp(sent), v)
            self._changed()

    def push_pose(self, pose: Any, frame: str, *, sent: float | None = None) -> None:
        """A goal pose (4, 4) in ``frame``."""
        T = np.array(pose, dtype=float)
        if T.shape != (4, 4) or not np.isfinite(T).all():
            raise ValueError(f"a pose is a finite 4x4 matrix, got shape {T.shape}")
        T.setflags(write=False)
        with self._lock:
            self._pose = Stamped(self._stamp(sent), T, str(frame))
            self._changed()

    def push_point(self, point: Any, frame: str, *, sent: float | None = None) -> None:
        """A goal point (3,) in ``frame``, m."""
        p = _vector(point, 3, "point")
        with self._lock:
            self._point = Stamped(self._stamp(sent), p, str(frame))
            self._changed()

    def push_image_point(self, uv: Any, camera: str, *, sent: float | None = None) -> None:
        """A click ``[u, v]`` (px) in the image of ``camera``."""
        p = _vector(uv, 2, "image point")
        with self._lock:
            self._image_point = Stamped(self._stamp(sent), p, str(camera))
            self._changed()

    def press(self, button: str) -> None:
        """One press of ``button`` (``handback``, ``mode:tool_velocity``, ``stop``...)."""
        with self._lock:
            self._presses[button] = self._presses.get(button, 0) + 1
            self._t = self._now()
            self._received += 1
            self._changed()

    def _stamp(self, sent: float | None) -> float:
        """Under the lock: the backend time the command was given (see the module docstring)."""
        now = self._now()
        self._t = now
        self._received += 1
        if sent is None or self._stamp_clock is None:
            return now
        delay = self._stamp_clock() - float(sent)
        if not np.isfinite(delay) or delay < 0.0:
            self._future += 1
            return now
        self._last_delay = delay
        return now - delay

    def _changed(self) -> None:
        """Under the lock: the sample readers get from now on (one object per change)."""
        assert self._t is not None
        self._sample = OperatorSample(
            t=self._t,
            deadman=True,
            velocity=self._velocity,
            pose=self._pose,
            point=self._point,
            image_point=self._image_point,
            presses=dict(self._presses),
        )

    # ------------------------------------------------------------------ device
    def latest(self) -> OperatorSample | None:
        with self._lock:
            return self._sample

    def health(self) -> Health:
        """OK while nothing is wrong with the input itself (a sender may or may not be
        connected: the info says which); the commands' freshness is the reader's to judge."""
        now = self._now()
        with self._lock:
            info: dict[str, Any] = {
                "senders": self._links,
                "received": self._received,
                "future_stamps": self._future,
                "last_delay_s": self._last_delay,
                "age_s": None if self._t is None else now - self._t,
            }
            return Health(HealthState.OK, now, self._link_note, info)


def _vector(values: Any, n: int, what: str) -> np.ndarray:
    v = np.array(values, dtype=float).reshape(-1)
    if v.shape != (n,) or not np.isfinite(v).all():
        raise ValueError(f"a {what} is {n} finite numbers, got {values!r}")
    v.setflags(write=False)
    return v
