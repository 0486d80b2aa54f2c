"""The pipe detector on the BlueROV2's one camera as a HAL
:class:`~hal.interfaces.TargetDetector` (``driver: mono_pipe_detector``).

The camera's H.264 stream arrives as RTP over UDP (:class:`hal.drivers.rtp_camera.RtpH264Camera`,
BlueOS's port 5600). A worker thread takes the newest decoded frame at
``rate_hz``, reads the vehicle's attitude and pose and the arm's joint angles
(:meth:`MonoPipeDetector.attach`, done by :mod:`hal.factory`), and runs the
monocular mode of the pipe detector (:class:`vision.monocular.MonocularPipeDetector`:
the pipe's known radius gives the depth) with gravity from the attitude, the
arm drawn out of the image from the URDF, and the camera mounted where the
URDF's ``stereo_camera`` frame is (the role's name is the KCL's; on this rig it
is the one camera). Detections go through the same tracker as the stereo
driver's (:mod:`hal.drivers.pipe_track`); :meth:`latest` returns the track.

Health: the camera's (MISSING before its first frame, FAULT when its frames
stop for ``stale_timeout_s``) and the detector's (DEGRADED with the reason when
images cannot be used, e.g. not the intrinsics' aspect ratio); ``info["parts"]``
has a row for each, as ``maris hal check`` shows them; ``info["starting"]``
until the first frame has been processed.
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

from hal.config import site_of
from hal.drivers.pipe_detector import detector_config
from hal.drivers.pipe_track import PipeTrack, image_context
from hal.drivers.rtp_camera import RtpH264Camera
from hal.drivers.setup_checks import SetupError
from hal.interfaces import Arm, CameraFrame, Detection, Health, HealthState, TargetDetector, Vehicle
from kcl.model import UvmsModel
from vision.calibration import CameraModel
from vision.monocular import MonocularPipeDetector
from vision.occlusion import arm_mask, arm_points_camera
from vision.overlay import jpeg_preview, overlay_primitives
from vision.pipeline import gravity_in_camera

log = logging.getLogger(__name__)

_ORDER = [HealthState.OK, HealthState.DEGRADED, HealthState.FAULT, HealthState.MISSING]
#: The URDF frame of the camera (the KCL's role name; the one camera on this rig).
CAMERA_FRAME = "stereo_camera"


def camera_model(p: dict[str, Any]) -> CameraModel:
    """The pinhole camera of a validated ``camera`` record (pixels; OpenCV distortion k1 k2 p1 p2 k3)."""
    K = np.array([[p["fx"], 0.0, p["cx"]], [0.0, p["fy"], p["cy"]], [0.0, 0.0, 1.0]], dtype=float)
    return CameraModel(int(p["width"]), int(p["height"]), K, np.asarray(p.get("distortion") or [], dtype=float))


class MonoPipeDetector(TargetDetector):
    """One RTP H.264 camera + the monocular pipe detector on a worker thread (see the module doc)."""

    name = "mono_pipe_detector"

    def __init__(self, params: dict[str, Any], clock: Callable[[], float]) -> None:
        self.params = params
        self._clock = clock
        self.camera_model = camera_model(params["camera"])
        self.detector = MonocularPipeDetector(self.camera_model, detector_config(params))
        self.model = UvmsModel.load(params.get("urdf"))
        self.vehicle_T_camera = self.model.frame_pose_vehicle(np.zeros(self.model.n_joints), CAMERA_FRAME)
        self.stream = RtpH264Camera(
            {**params.get("stream", {}), "stale_timeout_s": params.get("stale_timeout_s", 1.0)}, clock
        )
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
        self._last_frame_seq = 0
        self._last_log_t = -np.inf
        self._costs: deque[float] = deque(maxlen=20)
        self._runs: deque[float] = deque(maxlen=20)
        self.processed = 0
        self.detections = 0
        self.errors = 0
        self.last_error = ""
        self.warning = ""
        self.last_confidence: float | None = None

    def attach(self, vehicle: Vehicle | None = None, arm: Arm | None = None) -> None:
        """Where the attitude (gravity) and the joint angles (arm mask) come from."""
        self._vehicle, self._arm = vehicle, arm

    # ------------------------------------------------------------------ life cycle

    def connect(self) -> None:
        try:
            self.stream.connect()
        except OSError as exc:  # the port is taken, or the address is not this computer's
            raise SetupError(f"{site_of(self.params, 'stream')}: camera stream {self.stream.where}: {exc}") from None
        self._stop.clear()
        self._thread = threading.Thread(target=self._run, name="mono-pipe-detector", daemon=True)
        self._thread.start()

    def disconnect(self) -> None:
        self._stop.set()
        if self._thread is not None:
            self._thread.join(timeout=5.0)
            self._thread = None
        self.stream.disconnect()

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
            frame = self.stream.latest()
            if frame is None or frame.seq == self._last_frame_seq:
                continue
            self._last_frame_seq = frame.seq
            try:
                self.process(frame.t, frame.image)
            except Exception as exc:  # noqa: BLE001 - a bad frame must not stop the detector
                self.errors += 1
                self.last_error = f"{type(exc).__name__}: {exc}"
                log.warning("pipe detector: %s", self.last_error)

    def process(self, t: float, image: np.ndarray) -> Any:
        """Detect on one image of time ``t`` (also usable without the thread)."""
        t0 = time.perf_counter()
        ctx = image_context(self._vehicle, self._arm, self.model)
        self.warning = ctx.warning or self.warning
        gravity = None
        if ctx.attitude is not None and np.all(np.isfinite(ctx.attitude)):
            gravity = gravity_in_camera(ctx.attitude, self.vehicle_T_camera)
        mask = None
        if ctx.q is not None and np.all(np.isfinite(ctx.q)):
            cam = self.detector.camera_for(image.shape[1], image.shape[0])
            mask = arm_mask(cam, arm_points_camera(self.model, ctx.q, CAMERA_FRAME), self.detector.config.arm)
        det = self.detector.detect(image, gravity_cam=gravity, arm_mask=mask, vehicle_T_camera=self.vehicle_T_camera)
        self._costs.append(time.perf_counter() - t0)
        self._runs.append(time.monotonic())
        self.processed += 1
        self.last_confidence = det.confidence
        self.last_error = ""
        if det.found and det.vehicle_T_grasp is not None:
            self.detections += 1
            with self._lock:
                self._track.add(t, det, ctx)
                self._latest = self._track.output(self._clock())
        if t - self._last_log_t >= self.log_period:
            self._last_log_t = t
            jpeg, w, h, scale = jpeg_preview(image)
            cam = self.detector.camera_for(image.shape[1], image.shape[0])
            with self._lock:
                self._frames.append(
                    CameraFrame(t, "camera", jpeg, w, h, CAMERA_FRAME, overlay_primitives(det, cam, scale))
                )
        return det

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

    def health(self) -> Health:
        now = self._clock()
        cam = self.stream.health(now)
        runs = list(self._runs)
        rate = (len(runs) - 1) / (runs[-1] - runs[0]) if len(runs) >= 2 and runs[-1] > runs[0] else None
        cost = 1e3 * float(np.median(self._costs)) if self._costs else None
        det = self.latest()
        diag = {
            "rate_hz": None if rate is None else round(rate, 1),
            "processing_ms": None if cost is None else round(cost, 1),
            "frames": self.processed,
            "detections": self.detections,
            "errors": self.errors,
            "last_confidence": self.last_confidence,
            "last_detection_age_s": None if det is None else round(now - det.t, 3),
        }
        det_state, det_detail, starting = HealthState.OK, "", ""
        if self.last_error:
            det_state, det_detail = HealthState.DEGRADED, f"detector: {self.last_error}"
        elif self.warning:
            det_state, det_detail = HealthState.DEGRADED, f"detector: {self.warning}"
        elif self.processed == 0 and cam.state.usable:  # usable, not seen working yet: `maris hal check` waits
            starting = det_detail = "detector: no frame processed yet"
        parts = [
            {"name": "camera", "state": cam.state.value, "detail": cam.detail, **cam.info},
            {"name": "detector", "state": det_state.value, "detail": det_detail, **diag},
        ]
        info: dict[str, Any] = {"parts": parts}
        if starting:
            info["starting"] = starting
        worst = max([cam.state, det_state], key=_ORDER.index)
        detail = "; ".join(x for x in (cam.detail, det_detail) if x)
        return Health(worst, now, detail, info)
