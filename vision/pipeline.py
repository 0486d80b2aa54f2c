"""The detector with the vehicle around it: arm masks, gravity, the vehicle frame.

:class:`PipePoseEstimator` is what the HAL driver and the simulator run on
every image pair: from the joint angles it draws the arm's reprojection mask
(:mod:`vision.occlusion`, through :class:`kcl.model.UvmsModel`), from the
vehicle attitude (AHRS roll and pitch) the gravity direction in the camera
frame, and it reports the grasp frame in the vehicle frame too (``vTg``), the
camera being the URDF's ``stereo_camera`` frame (the left camera).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from vision.calibration import StereoCalibration
from vision.detector import DetectorConfig, PipeDetection, PipeDetector
from vision.occlusion import arm_masks, arm_points_camera

if TYPE_CHECKING:
    from kcl.model import UvmsModel


def gravity_in_camera(attitude_rpy: np.ndarray, vehicle_T_camera: np.ndarray) -> np.ndarray:
    """Unit down vector (3,) in the camera frame for vehicle roll, pitch, yaw (rad)."""
    from kcl.rotations import rpy_to_matrix

    wRv = rpy_to_matrix(*[float(x) for x in attitude_rpy])
    g_vehicle = wRv.T @ np.array([0.0, 0.0, 1.0])  # NED: down is +z
    return vehicle_T_camera[:3, :3].T @ g_vehicle


class PipePoseEstimator:
    """Detector + arm model + mounting. ``model`` None: no arm mask and the
    camera mounting ``vehicle_T_camera`` must be given (identity otherwise)."""

    def __init__(
        self,
        calib: StereoCalibration,
        config: DetectorConfig | None = None,
        model: UvmsModel | None = None,
        vehicle_T_camera: np.ndarray | None = None,
        camera_frame: str = "stereo_camera",
    ):
        self.detector = PipeDetector(calib, config if config is not None else DetectorConfig())
        self.model = model
        self.camera_frame = camera_frame
        if vehicle_T_camera is None and model is not None:
            vehicle_T_camera = model.frame_pose_vehicle(np.zeros(model.n_joints), camera_frame)
        self.vehicle_T_camera = np.eye(4) if vehicle_T_camera is None else np.asarray(vehicle_T_camera, dtype=float)

    @property
    def calib(self) -> StereoCalibration:
        return self.detector.calib

    def arm_masks(self, q: np.ndarray | None, width: int, height: int) -> tuple[np.ndarray, np.ndarray] | None:
        """Arm masks for images of ``width`` x ``height`` at joint angles ``q`` (None: no mask)."""
        if self.model is None or q is None or not np.all(np.isfinite(q)):
            return None
        calib = self.detector._calib(width, height)
        return arm_masks(calib, arm_points_camera(self.model, q, self.camera_frame), self.detector.config.arm)

    def estimate(
        self,
        left: np.ndarray,
        right: np.ndarray,
        *,
        attitude_rpy: np.ndarray | None = None,
        q: np.ndarray | None = None,
    ) -> PipeDetection:
        """Detect the pipe in a raw pair; ``attitude_rpy``: vehicle roll, pitch, yaw
        (rad) at the image time; ``q``: joint angles (rad) at the image time."""
        from vision.detector import check_pair

        check_pair(left, right)
        h, w = left.shape[:2]
        g = None
        if attitude_rpy is not None and np.all(np.isfinite(attitude_rpy)):
            g = gravity_in_camera(np.asarray(attitude_rpy, dtype=float), self.vehicle_T_camera)
        masks = self.arm_masks(q, w, h)
        return self.detector.detect(left, right, gravity_cam=g, arm_masks=masks, vehicle_T_camera=self.vehicle_T_camera)
