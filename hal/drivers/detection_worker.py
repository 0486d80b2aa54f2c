"""What a pipe-detector driver runs besides its detector: the paced worker thread,
the track of its detections, the frames it logs and the counters its health shows.

:class:`DetectionWorker` is composed by the stereo driver
(:mod:`hal.drivers.pipe_detector`) and the one-camera driver
(:mod:`hal.drivers.mono_detector`), which differ only in where their images come
from and which detector reads them. The worker takes the newest input at
``rate_hz`` (``next_input`` returns None when there is nothing new) and hands it to
the driver's ``process``, which detects and calls :meth:`DetectionWorker.record`;
an exception from one input is counted and logged, never the end of the thread.
The control loop only calls :meth:`DetectionWorker.latest` (a lock and a
reference copy): detection never blocks it.
"""

from __future__ import annotations

import logging
import threading
import time
from collections import deque
from collections.abc import Callable
from typing import Any

import cv2
import numpy as np

from hal.drivers.pipe_track import ImageContext, PipeTrack
from hal.interfaces import CameraFrame, Detection, HealthState

log = logging.getLogger(__name__)


class DetectionWorker:
    """The worker of a detector driver (see the module doc). ``params``: the driver's
    validated HAL entry (``rate_hz``, ``threads``, ``log_frames_hz``); ``clock``: the
    backend clock (s); ``name``: the thread's name."""

    def __init__(self, params: dict[str, Any], clock: Callable[[], float], name: str) -> None:
        self._clock = clock
        self.name = name
        self.period = 1.0 / float(params.get("rate_hz", 10.0))  # s between inputs
        self.threads = int(params.get("threads", 1))  # OpenCV's threads in the worker
        log_hz = float(params.get("log_frames_hz", 1.0))
        self.log_period = 1.0 / log_hz if log_hz > 0 else float("inf")  # s between logged frames
        self._lock = threading.Lock()
        self._latest: Detection | None = None
        self._track = PipeTrack()
        self._frames: deque[CameraFrame] = deque(maxlen=4)
        self._thread: threading.Thread | None = None
        self._stop = threading.Event()
        self._last_log_t = -np.inf
        self._costs: deque[float] = deque(maxlen=20)  # s of detection per input, last 20
        self._runs: deque[float] = deque(maxlen=20)  # monotonic s of the last 20 inputs
        self.processed = 0
        self.detections = 0
        self.errors = 0
        self.last_error = ""
        #: why the images cannot be used as configured (e.g. the arm mask is off)
        self.warning = ""
        self.last_confidence: float | None = None

    # ------------------------------------------------------------------ thread

    def start(self, next_input: Callable[[], tuple[Any, ...] | None], process: Callable[..., Any]) -> None:
        """Run ``process(*next_input())`` every period on a daemon thread."""
        self._stop.clear()
        self._thread = threading.Thread(target=self._run, args=(next_input, process), name=self.name, daemon=True)
        self._thread.start()

    def stop(self) -> None:
        self._stop.set()
        if self._thread is not None:
            self._thread.join(timeout=5.0)
            self._thread = None

    def _run(self, next_input: Callable[[], tuple[Any, ...] | None], process: Callable[..., Any]) -> None:
        try:
            cv2.setNumThreads(self.threads)
        except Exception:  # noqa: BLE001 - only a tuning knob
            pass
        next_t = time.monotonic()
        while not self._stop.is_set():
            delay = next_t - time.monotonic()
            if delay > 0 and self._stop.wait(delay):
                break
            next_t = max(next_t + self.period, time.monotonic())
            item = next_input()
            if item is None:
                continue
            try:
                process(*item)
            except Exception as exc:  # noqa: BLE001 - a bad frame must not stop the detector
                self.errors += 1
                self.last_error = f"{type(exc).__name__}: {exc}"
                log.warning("pipe detector: %s", self.last_error)

    # ------------------------------------------------------------------ results

    def note_context(self, ctx: ImageContext) -> None:
        """Keep the reason an input's context cannot be used as configured (e.g. the arm
        mask off), noted before its detection runs (which may fail)."""
        self.warning = ctx.warning or self.warning

    def record(self, t: float, det: Any, ctx: ImageContext, started: float) -> None:
        """One input's detection ``det`` of image time ``t`` (s), its context, and when
        (``time.perf_counter()``) its processing started."""
        self._costs.append(time.perf_counter() - started)
        self._runs.append(time.monotonic())
        self.processed += 1
        self.last_confidence = det.confidence
        self.last_error = ""
        if det.found and det.vehicle_T_grasp is not None:
            self.detections += 1
            with self._lock:
                self._track.add(t, det, ctx)
                self._latest = self._track.output(self._clock())

    def frame_due(self, t: float) -> bool:
        """Whether the image of time ``t`` (s) is to be logged (``log_frames_hz``)."""
        if t - self._last_log_t < self.log_period:
            return False
        self._last_log_t = t
        return True

    def add_frame(self, frame: CameraFrame) -> None:
        with self._lock:
            self._frames.append(frame)

    def latest(self) -> Detection | None:
        """The tracked detection, its confidence as of now (it falls while the track coasts)."""
        with self._lock:
            if self._latest is None:
                return None
            self._latest = self._track.output(self._clock())
            return self._latest

    def camera_frames(self) -> list[CameraFrame]:
        with self._lock:
            out = list(self._frames)
            self._frames.clear()
        return out

    # ------------------------------------------------------------------ health

    def stats(self, now: float) -> dict[str, Any]:
        """The detector's row of ``maris hal check``: rate (Hz), cost (ms), inputs,
        detections, errors, last confidence, age of the last detection (s)."""
        runs = list(self._runs)
        rate = (len(runs) - 1) / (runs[-1] - runs[0]) if len(runs) >= 2 and runs[-1] > runs[0] else None
        cost = 1e3 * float(np.median(self._costs)) if self._costs else None
        det = self.latest()
        return {
            "rate_hz": None if rate is None else round(rate, 1),
            "processing_ms": None if cost is None else round(cost, 1),
            "frames": self.processed,
            "detections": self.detections,
            "errors": self.errors,
            "last_confidence": self.last_confidence,
            "last_detection_age_s": None if det is None else round(now - det.t, 3),
        }

    def state(self) -> tuple[HealthState, str]:
        """DEGRADED with the reason when the last input failed or the images cannot be
        used as configured, else OK."""
        if self.last_error:
            return HealthState.DEGRADED, f"detector: {self.last_error}"
        if self.warning:
            return HealthState.DEGRADED, f"detector: {self.warning}"
        return HealthState.OK, ""
