"""A stereo pair: two :class:`~hal.drivers.camera.CameraSource` (or one source
delivering both images side by side) and the pairing of their frames.

``sync: time`` (live cameras): each camera grabs on its own thread; a pair is
the newest left frame and the right frame closest to it in time, accepted if
they are at most ``pairing_tolerance_s`` apart (hardware-triggered cameras
are within a millisecond; free-running ones at 10 fps within 50 ms).
``sync: sequence`` (recordings: two folders or two videos): one thread reads
both sources in lockstep, so frame ``i`` pairs with frame ``i``.
The pair's time is the mean of its two frames' times.
"""

from __future__ import annotations

import threading
import time
from collections.abc import Callable

import numpy as np

from hal.drivers.camera import CameraError, CameraSource, Frame
from hal.interfaces import Health, HealthState

_ORDER = [HealthState.OK, HealthState.DEGRADED, HealthState.FAULT, HealthState.MISSING]


class StereoCamera:
    """The two cameras of the rig. ``params``: ``left`` / ``right`` (camera
    params) or ``side_by_side``, ``sync``, ``pairing_tolerance_s``, ``stale_timeout_s``."""

    def __init__(self, params: dict, clock: Callable[[], float]):
        self._clock = clock
        self.tolerance = float(params.get("pairing_tolerance_s", 0.02))
        self.stale_timeout = float(params.get("stale_timeout_s", 0.5))
        self.sync = params.get("sync") or "time"
        sbs = params.get("side_by_side")
        stale = {"stale_timeout": self.stale_timeout}
        if sbs:
            self.cameras = {"stereo": CameraSource("stereo", {**sbs, **stale}, clock)}
        else:
            self.cameras = {
                "left": CameraSource("left", {**params["left"], **stale}, clock),
                "right": CameraSource("right", {**params["right"], **stale}, clock),
            }
        self.side_by_side = bool(sbs)
        self._thread: threading.Thread | None = None
        self._stop = threading.Event()
        self.pairs_rejected = 0

    def connect(self) -> None:
        """Open the camera(s); raise :class:`CameraError` naming the one that failed."""
        lockstep = self.sync == "sequence" and not self.side_by_side
        opened = []
        try:
            for cam in self.cameras.values():
                cam.connect(start_thread=not lockstep)
                opened.append(cam)
        except CameraError:
            for cam in opened:
                cam.disconnect()
            raise
        if lockstep:
            self._stop.clear()
            self._thread = threading.Thread(target=self._lockstep, name="stereo-lockstep", daemon=True)
            self._thread.start()

    def disconnect(self) -> None:
        self._stop.set()
        if self._thread is not None:
            self._thread.join(timeout=3.0)
            self._thread = None
        for cam in self.cameras.values():
            cam.disconnect()

    def _lockstep(self) -> None:
        left, right = self.cameras["left"], self.cameras["right"]
        period = left._period or right._period or 0.1
        next_t = time.monotonic()
        while not self._stop.is_set():
            delay = next_t - time.monotonic()
            if delay > 0 and self._stop.wait(delay):
                break
            next_t = max(next_t + period, time.monotonic() - period)
            a, _ = left.grab_once()
            b, _ = right.grab_once()
            if a == "none" or b == "none":
                for cam in (left, right):
                    cam.ended = True
                    cam.last_error = "end of the recording"
                break

    def latest_pair(self) -> tuple[float, np.ndarray, np.ndarray] | None:
        """``(t, left, right)`` of the newest valid pair, or None."""
        if self.side_by_side:
            f = self.cameras["stereo"].latest()
            if f is None:
                return None
            w = f.image.shape[1] // 2
            return f.t, f.image[:, :w], f.image[:, w : 2 * w]
        left, right = self.cameras["left"], self.cameras["right"]
        if self.sync == "sequence":
            hl = {f.seq: f for f in left.history()}
            for fr in reversed(right.history()):
                fl = hl.get(fr.seq)
                if fl is not None:
                    return 0.5 * (fl.t + fr.t), fl.image, fr.image
            return None
        fl = left.latest()
        if fl is None:
            return None
        best: Frame | None = None
        for fr in right.history():
            if best is None or abs(fr.t - fl.t) < abs(best.t - fl.t):
                best = fr
        if best is None:
            return None
        if abs(best.t - fl.t) > self.tolerance:
            self.pairs_rejected += 1
            return None
        return 0.5 * (fl.t + best.t), fl.image, best.image

    def details(self, now: float) -> dict:
        return {name: cam.details(now) for name, cam in self.cameras.items()}

    def health(self, now: float) -> Health:
        """Worst of the cameras (a stale camera is a FAULT), details per camera."""
        parts = {name: cam.health(now) for name, cam in self.cameras.items()}
        worst = max((h.state for h in parts.values()), key=_ORDER.index)
        detail = "; ".join(h.detail for h in parts.values() if h.detail)
        return Health(worst, now, detail, {name: h.info for name, h in parts.items()})
