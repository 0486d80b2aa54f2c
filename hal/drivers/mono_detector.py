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
import time
from collections.abc import Callable
from typing import Any

import numpy as np

from hal.config import site_of
from hal.drivers.detection_worker import DetectionWorker
from hal.drivers.pipe_detector import detector_config
from hal.drivers.pipe_track import image_context
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
        self.worker = DetectionWorker(params, clock, "mono-pipe-detector")
        self._vehicle: Vehicle | None = None
        self._arm: Arm | None = None
        self._last_frame_seq = 0

    def attach(self, vehicle: Vehicle | None = None, arm: Arm | None = None) -> None:
        """Where the attitude (gravity) and the joint angles (arm mask) come from."""
        self._vehicle, self._arm = vehicle, arm

    # ------------------------------------------------------------------ life cycle

    def connect(self) -> None:
        try:
            self.stream.connect()
        except OSError as exc:  # the port is taken, or the address is not this computer's
            raise SetupError(f"{site_of(self.params, 'stream')}: camera stream {self.stream.where}: {exc}") from None
        self.worker.start(self._next_frame, self.process)

    def disconnect(self) -> None:
        self.worker.stop()
        self.stream.disconnect()

    def _next_frame(self) -> tuple[float, np.ndarray] | None:
        """The newest decoded frame, if newer than the last one processed."""
        frame = self.stream.latest()
        if frame is None or frame.seq == self._last_frame_seq:
            return None
        self._last_frame_seq = frame.seq
        return frame.t, frame.image

    # ------------------------------------------------------------------ worker

    def process(self, t: float, image: np.ndarray) -> Any:
        """Detect on one image of time ``t`` (also usable without the thread)."""
        t0 = time.perf_counter()
        ctx = image_context(self._vehicle, self._arm, self.model)
        self.worker.note_context(ctx)
        gravity = None
        if ctx.attitude is not None and np.all(np.isfinite(ctx.attitude)):
            gravity = gravity_in_camera(ctx.attitude, self.vehicle_T_camera)
        mask = None
        if ctx.q is not None and np.all(np.isfinite(ctx.q)):
            cam = self.detector.camera_for(image.shape[1], image.shape[0])
            mask = arm_mask(cam, arm_points_camera(self.model, ctx.q, CAMERA_FRAME), self.detector.config.arm)
        det = self.detector.detect(image, gravity_cam=gravity, arm_mask=mask, vehicle_T_camera=self.vehicle_T_camera)
        self.worker.record(t, det, ctx, t0)
        if self.worker.frame_due(t):
            jpeg, w, h, scale = jpeg_preview(image)
            cam = self.detector.camera_for(image.shape[1], image.shape[0])
            self.worker.add_frame(
                CameraFrame(t, "camera", jpeg, w, h, CAMERA_FRAME, overlay_primitives(det, cam, scale))
            )
        return det

    # ------------------------------------------------------------------ HAL

    def latest(self) -> Detection | None:
        """The tracked detection, its confidence as of now (it falls while the track coasts)."""
        return self.worker.latest()

    def camera_frames(self) -> list[CameraFrame]:
        return self.worker.camera_frames()

    def health(self) -> Health:
        now = self._clock()
        cam = self.stream.health(now)
        det_state, det_detail = self.worker.state()
        starting = ""
        if det_state is HealthState.OK and self.worker.processed == 0 and cam.state.usable:
            starting = det_detail = "detector: no frame processed yet"  # not seen working yet: hal check waits
        parts = [
            {"name": "camera", "state": cam.state.value, "detail": cam.detail, **cam.info},
            {"name": "detector", "state": det_state.value, "detail": det_detail, **self.worker.stats(now)},
        ]
        info: dict[str, Any] = {"parts": parts}
        if starting:
            info["starting"] = starting
        worst = max([cam.state, det_state], key=_ORDER.index)
        detail = "; ".join(x for x in (cam.detail, det_detail) if x)
        return Health(worst, now, detail, info)
