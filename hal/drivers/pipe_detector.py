"""The MARIS stereo pipe detector as a HAL :class:`~hal.interfaces.TargetDetector`.

Cameras (:class:`hal.drivers.stereo.StereoCamera`) grab on their own threads;
a worker thread takes the newest stereo pair at ``rate_hz`` (about 10 Hz in
MARIS), reads the vehicle attitude and the joint angles from the vehicle and
arm drivers (:meth:`StereoPipeDetector.attach`, done by :mod:`hal.factory`),
and runs :class:`vision.pipeline.PipePoseEstimator`. The control loop only
calls :meth:`latest` (a lock and a reference copy): detection never blocks it.

Detections go through a tracker (:class:`vision.tracking.DetectionTracker`):
in the world frame of the vehicle's navigation (position and attitude at the
image time), or in the vehicle frame when there is no navigation. One wrong
detection is gated out, the pipe end (the position along the axis) is held
between the images that show it, and a pipe that moved is reacquired. What
:meth:`latest` returns is the track: its time is the image time of the last
accepted detection, its pose the filtered grasp frame in the vehicle frame at
that time (``vTg``), its confidence that of the detections that saw an end
(the detector's own no-end confidence when none was seen for 1.5 s), falling
once the track coasts (no accepted detection for 0.3 s, then halving every
0.5 s); ``details`` carry the last raw detection (camera-frame poses, visible
end, quality factors) and ``details["tracker"]`` the track's state
(``tracking`` / ``no recent end`` / ``coasting``, ages, accepted and rejected
counts). A pair without the pipe gives no new detection (consumers check the
age). Health: a missing or stale camera (no frame for
``stale_timeout_s``) is a FAULT; pairs that never match in time, or images
the detector cannot use (e.g. not the calibration's size), make it DEGRADED
with the reason; ``details`` show per camera its resolution, frame rate and
the age of its last frame, and the detector's own rate and cost.
"""

from __future__ import annotations

import logging
import os
import threading
import time
from collections import deque
from collections.abc import Callable
from typing import Any

import cv2
import numpy as np

from hal.drivers.camera import CameraError
from hal.drivers.pipe_track import PipeTrack, image_context
from hal.drivers.stereo import StereoCamera
from hal.interfaces import Arm, CameraFrame, Detection, Health, HealthState, TargetDetector, Vehicle
from kcl.model import UvmsModel
from vision.calibration import load_stereo_calibration
from vision.detector import DetectorConfig, calibration_for
from vision.occlusion import ArmShape
from vision.overlay import jpeg_preview, overlay_primitives
from vision.pipeline import PipePoseEstimator
from vision.silhouette import HsvRange

_ORDER = [HealthState.OK, HealthState.DEGRADED, HealthState.FAULT, HealthState.MISSING]

log = logging.getLogger(__name__)


def detector_config(params: dict) -> DetectorConfig:
    """The :class:`vision.detector.DetectorConfig` of a validated HAL entry."""

    hsv = params.get("hsv") or {}
    pipe = params.get("pipe") or {}
    arm = params.get("arm_mask") or {}
    base = DetectorConfig()
    return DetectorConfig(
        hsv=HsvRange(
            hue=tuple(hsv.get("hue") or base.hsv.hue),
            sat_min=int(hsv.get("sat_min", base.hsv.sat_min)),
            val_min=int(hsv.get("val_min", base.hsv.val_min)),
        ),
        pipe_radius_m=float(pipe.get("radius_m", base.pipe_radius_m)),
        pipe_length_m=float(pipe.get("length_m", base.pipe_length_m)),
        grasp_from_end_m=pipe.get("grasp_from_end_m"),
        arm=ArmShape(
            float(arm.get("link_radius_m", 0.07)), float(arm.get("hand_radius_m", 0.10)), int(arm.get("margin_px", 4))
        ),
    )


class StereoPipeDetector(TargetDetector):
    """Stereo cameras + the pipe detector on a worker thread (see the module doc)."""

    name = "stereo_pipe_detector"

    def __init__(self, params: dict, clock: Callable[[], float]):
        self.params = params
        self.check_setup()  # before the heavy imports below: a start that cannot work fails at once
        # imported here, not at the first logged frame (in the detector thread, beside the loop)
        self._clock = clock
        self.params = params
        self.calib = load_stereo_calibration(params["calibration"], params.get("calibration_right"))
        model = UvmsModel.load(params.get("urdf"))
        self.estimator = PipePoseEstimator(self.calib, detector_config(params), model)
        self.stereo = StereoCamera(params, clock)
        self.period = 1.0 / float(params.get("rate_hz", 10.0))
        self.threads = int(params.get("threads", 1))
        log_hz = float(params.get("log_frames_hz", 1.0))
        self.log_period = 1.0 / log_hz if log_hz > 0 else float("inf")
        self._vehicle: Vehicle | None = None
        self._arm: Arm | None = None
        self._lock = threading.Lock()
        self._latest: Detection | None = None
        self._track = PipeTrack()
        self._frames: deque[CameraFrame] = deque(maxlen=4)
        self._thread: threading.Thread | None = None
        self._stop = threading.Event()
        self._last_pair_t: float | None = None
        self._last_log_t = -np.inf
        self._costs: deque[float] = deque(maxlen=20)
        self._runs: deque[float] = deque(maxlen=20)
        self.processed = 0
        self.errors = 0
        self.last_error = ""
        self.warning = ""
        self.last_confidence: float | None = None
        self.last_reason = ""

    def attach(self, vehicle: Vehicle | None = None, arm: Arm | None = None) -> None:
        """Where the attitude (gravity) and the joint angles (arm mask) come from."""
        self._vehicle, self._arm = vehicle, arm

    # ------------------------------------------------------------------ life cycle

    def check_setup(self) -> None:
        """Cameras that cannot exist as configured, now (SetupError naming the field): a
        V4L2 device that is not there, a stream URL whose host does not resolve."""
        from urllib.parse import urlsplit

        from hal.config import site_of
        from hal.drivers.setup_checks import SetupError, resolve_host

        for name in ("left", "right", "side_by_side"):
            cam = self.params.get(name)
            if not cam:
                continue
            source = str(cam.get("source", "")).strip()
            where = site_of(self.params, name, "source")
            device = f"/dev/video{source}" if source.isdigit() else source if source.startswith("/dev/") else None
            if device is not None and not os.path.exists(device):
                raise SetupError(f"{where}: {name} camera: video device {device} does not exist on this computer")
            if "://" in source and "!" not in source:
                host = urlsplit(source).hostname
                if host:
                    resolve_host(host, where, f"{name} camera")

    def connect(self) -> None:
        self.check_setup()
        try:
            self.stereo.connect()
        except CameraError as exc:
            from hal.config import site_of
            from hal.drivers.setup_checks import SetupError

            raise SetupError(f"{site_of(self.params)}: {exc}") from None
        self._stop.clear()
        self._thread = threading.Thread(target=self._run, name="pipe-detector", daemon=True)
        self._thread.start()

    def disconnect(self) -> None:
        self._stop.set()
        if self._thread is not None:
            self._thread.join(timeout=5.0)
            self._thread = None
        self.stereo.disconnect()

    # ------------------------------------------------------------------ worker

    def _run(self) -> None:
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
            pair = self.stereo.latest_pair()
            if pair is None or (self._last_pair_t is not None and pair[0] <= self._last_pair_t):
                continue
            self._last_pair_t = pair[0]
            try:
                self.process(*pair)
            except Exception as exc:  # noqa: BLE001 - a bad frame must not stop the detector
                self.errors += 1
                self.last_error = f"{type(exc).__name__}: {exc}"
                log.warning("pipe detector: %s", self.last_error)

    def process(self, t: float, left: np.ndarray, right: np.ndarray) -> Any:
        """Detect on one pair of image time ``t`` (also usable without the thread)."""
        t0 = time.perf_counter()
        ctx = image_context(self._vehicle, self._arm, self.estimator.model)
        self.warning = ctx.warning or self.warning
        det = self.estimator.estimate(left, right, attitude_rpy=ctx.attitude, q=ctx.q)
        self._costs.append(time.perf_counter() - t0)
        self._runs.append(time.monotonic())
        self.processed += 1
        self.last_confidence, self.last_reason = det.confidence, det.reason
        self.last_error = ""
        if det.found and det.vehicle_T_grasp is not None:
            with self._lock:
                self._track.add(t, det, ctx)
                self._latest = self._track.output(self._clock())
        if t - self._last_log_t >= self.log_period:
            self._last_log_t = t
            self._log_frame(t, left, det)
        return det

    def _log_frame(self, t: float, left: np.ndarray, det: Any) -> None:
        jpeg, w, h, scale = jpeg_preview(left)
        calib = calibration_for(self.calib, left.shape[1], left.shape[0])
        with self._lock:
            self._frames.append(
                CameraFrame(t, "left", jpeg, w, h, "stereo_camera", overlay_primitives(det, calib, scale))
            )

    # ------------------------------------------------------------------ HAL

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

    def details(self, now: float) -> dict:
        """Cameras (resolution, fps, frame age) and the detector (rate, cost, last result)."""
        runs = list(self._runs)
        rate = (len(runs) - 1) / (runs[-1] - runs[0]) if len(runs) >= 2 and runs[-1] > runs[0] else None
        cost = 1e3 * float(np.median(self._costs)) if self._costs else None
        det = self.latest()
        return {
            "cameras": self.stereo.details(now),
            "detector": {
                "rate_hz": None if rate is None else round(rate, 1),
                "processing_ms": None if cost is None else round(cost, 1),
                "pairs": self.processed,
                "errors": self.errors,
                "last_confidence": self.last_confidence,
                "last_detection_age_s": None if det is None else round(now - det.t, 3),
            },
        }

    def health(self) -> Health:
        """Worst of the cameras and the detector; ``info["parts"]``: one row per
        camera (resolution, fps, frame age...) and one for the detector (rate,
        cost, pairs, last confidence), as ``maris hal check`` shows them;
        ``info["starting"]`` until the first pair has been processed."""
        now = self._clock()
        cams = {name: cam.health(now) for name, cam in self.stereo.cameras.items()}
        d = self.details(now)
        det_state, det_detail, starting = HealthState.OK, "", ""
        if self.last_error:
            det_state, det_detail = HealthState.DEGRADED, f"detector: {self.last_error}"
        elif self.warning:
            det_state, det_detail = HealthState.DEGRADED, f"detector: {self.warning}"
        elif self._last_pair_t is None and self.stereo.pairs_rejected > 0:
            det_state, det_detail = (
                HealthState.DEGRADED,
                f"cameras: no pair within {self.stereo.tolerance:.3f} s of each other yet",
            )
        elif self.processed == 0:  # usable, but not seen working yet: `maris hal check` waits for it
            starting = det_detail = "detector: no pair processed yet"
        parts = [
            {"name": f"camera {name}", "state": h.state.value, "detail": h.detail, **h.info} for name, h in cams.items()
        ]
        parts.append({"name": "detector", "state": det_state.value, "detail": det_detail, **d["detector"]})
        info: dict = {"parts": parts}
        if starting:
            info["starting"] = starting
        worst = max([h.state for h in cams.values()] + [det_state], key=_ORDER.index)
        detail = "; ".join(x for x in [h.detail for h in cams.values()] + [det_detail] if x)
        return Health(worst, now, detail, info)
