"""Arm occlusion: where the arm appears in each camera image (MARIS's "arm reprojector").

The arm is drawn as capsules (cylinders with round ends) of ``link_radius``
around the segments joining its joint origins and the tool point, plus a ball
of ``hand_radius`` around the tool point for the hand and fingers, from the
joint angles through the UVMS model (:class:`kcl.model.UvmsModel`, the URDF).
The pipe detector removes these pixels, dilated by ``margin_px``, from the
colour region, and ignores contour points next to them: the arm's outline in
front of the pipe is not an edge of the pipe.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import cv2
import numpy as np

from vision.calibration import CameraModel, StereoCalibration, project_points

if TYPE_CHECKING:
    from kcl.model import UvmsModel

_SAMPLES = np.linspace(0.0, 1.0, 4)


@dataclass(frozen=True)
class ArmShape:
    """Arm size for the mask: link radius (m), hand radius (m), extra margin (px)."""

    link_radius: float = 0.07
    hand_radius: float = 0.10
    margin_px: int = 4


def arm_points_camera(model: UvmsModel, q: np.ndarray, camera_frame: str = "stereo_camera") -> np.ndarray:
    """Arm polyline (k, 3) in the left camera frame: joint origins then the tool point (m)."""
    q = np.asarray(q, dtype=float)
    vTc = model.frame_pose_vehicle(q, camera_frame)
    cTv_R, cTv_t = vTc[:3, :3].T, -vTc[:3, :3].T @ vTc[:3, 3]
    pts = np.array([model.frame_pose_vehicle(q, f)[:3, 3] for f in tuple(model.joint_names) + ("tool",)])
    return pts @ cTv_R.T + cTv_t


def _draw_camera(mask: np.ndarray, cam: CameraModel, pts_cam: np.ndarray, shape: ArmShape, near: float = 0.05) -> None:
    fx = float(cam.K[0, 0])
    segs = []
    for a, b in zip(pts_cam[:-1], pts_cam[1:]):
        segs.append((a[None, :] + _SAMPLES[:, None] * (b - a)[None, :], shape.link_radius))
    segs.append((pts_cam[-1:], shape.hand_radius))
    for samples, radius in segs:
        front = samples[samples[:, 2] > near]
        if len(front) == 0:
            continue
        uv = project_points(front, cam)
        rad = fx * radius / front[:, 2] + shape.margin_px
        ok = np.all(np.isfinite(uv), axis=1) & (np.abs(uv).max(axis=1) < 1e5)
        uv, rad = uv[ok], rad[ok]
        for i in range(len(uv)):
            cv2.circle(mask, (int(round(uv[i, 0])), int(round(uv[i, 1]))), int(np.ceil(rad[i])), 255, -1)
            if i + 1 < len(uv):
                r = int(np.ceil(min(rad[i], rad[i + 1]) * 2))
                cv2.line(
                    mask,
                    (int(round(uv[i, 0])), int(round(uv[i, 1]))),
                    (int(round(uv[i + 1, 0])), int(round(uv[i + 1, 1]))),
                    255,
                    r,
                )


def arm_mask(cam: CameraModel, arm_pts: np.ndarray, shape: ArmShape = ArmShape()) -> np.ndarray:
    """uint8 mask (255 = arm) for one camera's image (a one-camera rig), from the arm
    polyline ``arm_pts`` (k, 3) in that camera's frame."""
    mask = np.zeros((cam.height, cam.width), np.uint8)
    if arm_pts is not None and len(arm_pts) > 0:
        _draw_camera(mask, cam, arm_pts, shape)
    return mask


def arm_masks(
    calib: StereoCalibration, arm_pts_left: np.ndarray, shape: ArmShape = ArmShape()
) -> tuple[np.ndarray, np.ndarray]:
    """uint8 masks (255 = arm) for the left and right images, from the arm
    polyline ``arm_pts_left`` (k, 3) in the left camera frame."""
    left = np.zeros((calib.left.height, calib.left.width), np.uint8)
    right = np.zeros((calib.right.height, calib.right.width), np.uint8)
    if arm_pts_left is None or len(arm_pts_left) == 0:
        return left, right
    _draw_camera(left, calib.left, arm_pts_left, shape)
    _draw_camera(right, calib.right, arm_pts_left @ calib.R.T + calib.T, shape)
    return left, right
