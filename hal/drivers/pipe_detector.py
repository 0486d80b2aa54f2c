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
import time
from collections.abc import Callable
from typing import Any

import numpy as np

from hal.drivers.camera import CameraError
from hal.drivers.detection_worker import DetectionWorker
from hal.drivers.pipe_track import image_context
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
        min_reported_confidence=float(params.get("min_reported_confidence", base.min_reported_confidence)),
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
        self.worker = DetectionWorker(params, clock, "pipe-detector")
        self._vehicle: Vehicle | None = None
        self._arm: Arm | None = None
        self._last_pair_t: float | None = None
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
        self.worker.start(self._next_pair, self.process)

    def disconnect(self) -> None:
        self.worker.stop()
        self.stereo.disconnect()

    def _next_pair(self) -> tuple[float, np.ndarray, np.ndarray] | None:
        """The newest pair, if newer than the last one processed."""
        pair = self.stereo.latest_pair()
        if pair is None or (self._last_pair_t is not None and pair[0] <= self._last_pair_t):
            return None
        self._last_pair_t = pair[0]
        return pair

    # ------------------------------------------------------------------ worker

    def process(self, t: float, left: np.ndarray, right: np.ndarray) -> Any:
        """Detect on one pair of image time ``t`` (also usable without the thread)."""
        t0 = time.perf_counter()
        ctx = image_context(self._vehicle, self._arm, self.estimator.model)
        self.worker.note_context(ctx)
        det = self.estimator.estimate(left, right, attitude_rpy=ctx.attitude, q=ctx.q)
        self.last_reason = det.reason
        self.worker.record(t, det, ctx, t0)
        if self.worker.frame_due(t):
            self._log_frame(t, left, det)
        return det

    def _log_frame(self, t: float, left: np.ndarray, det: Any) -> None:
        jpeg, w, h, scale = jpeg_preview(left)
        calib = calibration_for(self.calib, left.shape[1], left.shape[0])
        self.worker.add_frame(
            CameraFrame(t, "left", jpeg, w, h, "stereo_camera", overlay_primitives(det, calib, scale))
        )

    # ------------------------------------------------------------------ HAL

    def latest(self) -> Detection | None:
        """The tracked detection, its confidence as of now (it falls while the track coasts)."""
        return self.worker.latest()

    def camera_frames(self) -> list[CameraFrame]:
        return self.worker.camera_frames()

    def health(self) -> Health:
        """Worst of the cameras and the detector; ``info["parts"]``: one row per
        camera (resolution, fps, frame age...) and one for the detector (rate,
        cost, pairs, last confidence), as ``maris hal check`` shows them;
        ``info["starting"]`` until the first pair has been processed."""
        now = self._clock()
        cams = {name: cam.health(now) for name, cam in self.stereo.cameras.items()}
        det_state, det_detail = self.worker.state()
        starting = ""
        if det_state is HealthState.OK and self._last_pair_t is None and self.stereo.pairs_rejected > 0:
            det_state, det_detail = (
                HealthState.DEGRADED,
                f"cameras: no pair within {self.stereo.tolerance:.3f} s of each other yet",
            )
        elif det_state is HealthState.OK and self.worker.processed == 0:  # not seen working yet: hal check waits
            starting = det_detail = "detector: no pair processed yet"
        parts = [
            {"name": f"camera {name}", "state": h.state.value, "detail": h.detail, **h.info} for name, h in cams.items()
        ]
        parts.append({"name": "detector", "state": det_state.value, "detail": det_detail, **self.worker.stats(now)})
        info: dict = {"parts": parts}
        if starting:
            info["starting"] = starting
        worst = max([h.state for h in cams.values()] + [det_state], key=_ORDER.index)
        detail = "; ".join(x for x in [h.detail for h in cams.values()] + [det_detail] if x)
        return Health(worst, now, detail, info)
