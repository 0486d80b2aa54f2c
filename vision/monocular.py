"""The pipe detector on ONE camera (vehicles with a single camera, e.g. a stock BlueROV2).

With a known radius, the two straight edges of the pipe in one image fix its
axis: each edge and the camera centre span a plane tangent to the pipe; the
two planes meet in a line through the camera centre parallel to the axis, and
the axis lies on the plane bisecting them at ``radius / sin(theta / 2)`` from
that line, ``theta`` the angle between the planes
(:func:`vision.cylinder.axis_from_one_camera`). The depth rests on the
apparent width: an edge error of a fraction of a pixel is a depth error that
grows with the square of the range (the confidence's geometry factor says
so); the ends along the axis, the joint refinement, the grasp frame and the
confidence are those of the stereo detector (:class:`vision.detector.PipeEngine`).
docs/vision.md gives its accuracy against stereo on the evaluation set.
"""

from __future__ import annotations

import time

import numpy as np

from vision.calibration import CameraModel
from vision.detector import DetectorConfig, PipeDetection, PipeEngine
from vision.errors import VisionInputError

_DEFAULT_CONFIG = DetectorConfig()


class MonocularPipeDetector:
    """The detector for one calibrated camera (its frame is the detection's camera frame)."""

    def __init__(self, camera: CameraModel, config: DetectorConfig = _DEFAULT_CONFIG):
        self.engine = PipeEngine(config)
        self.camera = camera
        self._scaled: dict[tuple[int, int], CameraModel] = {}

    @property
    def config(self) -> DetectorConfig:
        return self.engine.config

    def camera_for(self, w: int, h: int) -> CameraModel:
        """The camera model for images of ``w`` x ``h`` (the calibration scaled to them)."""
        cam = self._scaled.get((w, h))
        if cam is None:
            cw, ch = self.camera.size
            if (cw, ch) == (w, h):
                cam = self.camera
            else:
                sx, sy = w / cw, h / ch
                if abs(sx - sy) > 2.0 / min(cw, ch):
                    raise VisionInputError(
                        f"image is {w}x{h} but the calibration is for {cw}x{ch} (a different aspect ratio)"
                    )
                cam = self.camera.scaled(sx, sy)
            self._scaled[(w, h)] = cam
        return cam

    def detect(
        self,
        image: np.ndarray,
        *,
        gravity_cam: np.ndarray | None = None,
        arm_mask: np.ndarray | None = None,
        vehicle_T_camera: np.ndarray | None = None,
    ) -> PipeDetection:
        """Detect the pipe in one raw BGR image (see :meth:`vision.detector.PipeDetector.detect`)."""
        t0 = time.perf_counter()
        if image is None:
            raise VisionInputError("image: missing (no frame)")
        if not isinstance(image, np.ndarray) or image.size == 0:
            raise VisionInputError("image: empty or corrupt frame")
        if image.ndim != 3 or image.shape[2] != 3 or image.dtype != np.uint8:
            raise VisionInputError(
                f"image: expected an 8-bit colour (BGR) image, got shape {image.shape} {image.dtype}"
            )
        h, w = image.shape[:2]
        cam = self.camera_for(w, h)
        det = self.engine.detect_views(
            [("left", image)],
            [(cam, np.eye(3), np.zeros(3))],
            None if arm_mask is None else [arm_mask],
            gravity_cam,
            vehicle_T_camera,
        )
        det.elapsed_ms = (time.perf_counter() - t0) * 1e3
        return det
