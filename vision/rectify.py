"""Stereo rectification (OpenCV ``stereoRectify`` + ``initUndistortRectifyMap``).

The rectified frames are rotations of the camera frames (``X_rect = R1 @ X_l``,
``R2 @ X_r``) in which epipolar lines are image rows and both cameras share
one pinhole matrix (``P1``, ``P2 = P1 + [.., f' * -baseline]``). The pipe
detector itself fits undistorted edge points in the original camera frames
and does not need rectified images; rectification is for viewing, for the
operators' own tools (disparity, measuring) and for checking a calibration:
a feature seen by both cameras must land on the same row.
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

from vision.calibration import StereoCalibration
from vision.errors import VisionInputError


@dataclass(frozen=True)
class Rectification:
    """Rectification of one calibration. R1, R2: (3, 3) rotations from the left /
    right camera frames to the rectified frames; P1, P2: (3, 4) rectified
    projections (px); Q: (4, 4) disparity-to-depth matrix; maps for ``cv2.remap``."""

    calib: StereoCalibration
    R1: np.ndarray
    R2: np.ndarray
    P1: np.ndarray
    P2: np.ndarray
    Q: np.ndarray
    maps: tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]

    @property
    def focal_px(self) -> float:
        """Rectified focal length (px)."""
        return float(self.P1[0, 0])

    @property
    def baseline(self) -> float:
        """Baseline (m) along the rectified x axis."""
        return float(-self.P2[0, 3] / self.P2[0, 0])

    def rectify(self, left: np.ndarray, right: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Rectified copies of a raw image pair (same size as the calibration)."""
        size = self.calib.left.size
        for name, img in (("left", left), ("right", right)):
            if img is None or img.ndim < 2 or (img.shape[1], img.shape[0]) != size:
                got = (
                    "nothing"
                    if img is None
                    else f"{img.shape[1]}x{img.shape[0]}"
                    if img.ndim >= 2
                    else f"shape {img.shape}"
                )
                raise VisionInputError(
                    f"{name} image: expected {size[0]}x{size[1]} (the calibration's size), got {got}"
                )
        m1x, m1y, m2x, m2y = self.maps
        return cv2.remap(left, m1x, m1y, cv2.INTER_LINEAR), cv2.remap(right, m2x, m2y, cv2.INTER_LINEAR)

    def disparity_to_depth(self, disparity_px: float) -> float:
        """Depth (m) along the rectified optical axis of a disparity (px)."""
        return self.focal_px * self.baseline / disparity_px if disparity_px > 0 else float("inf")


def rectify_calibration(calib: StereoCalibration, alpha: float = 0.0) -> Rectification:
    """Rectification maps of ``calib``; ``alpha`` 0 keeps only valid pixels, 1 keeps all."""
    if calib.left.size != calib.right.size:
        raise VisionInputError(f"rectification needs cameras of one size, got {calib.left.size} and {calib.right.size}")
    size = calib.left.size
    if calib.left.model != calib.right.model:
        raise VisionInputError(
            f"rectification needs one lens model for both cameras, got {calib.left.model} and {calib.right.model}"
        )
    if calib.left.model == "equidistant":
        R1, R2, P1, P2, Q = cv2.fisheye.stereoRectify(
            calib.left.K,
            calib.left.D,
            calib.right.K,
            calib.right.D,
            size,
            calib.R,
            calib.T.reshape(3, 1),
            flags=cv2.CALIB_ZERO_DISPARITY,
            balance=alpha,
        )
        m1 = cv2.fisheye.initUndistortRectifyMap(calib.left.K, calib.left.D, R1, P1, size, cv2.CV_32FC1)
        m2 = cv2.fisheye.initUndistortRectifyMap(calib.right.K, calib.right.D, R2, P2, size, cv2.CV_32FC1)
        return Rectification(calib, R1, R2, P1, P2, Q, (m1[0], m1[1], m2[0], m2[1]))
    R1, R2, P1, P2, Q, _, _ = cv2.stereoRectify(
        calib.left.K,
        calib.left.D,
        calib.right.K,
        calib.right.D,
        size,
        calib.R,
        calib.T.reshape(3, 1),
        flags=cv2.CALIB_ZERO_DISPARITY,
        alpha=alpha,
    )
    m1 = cv2.initUndistortRectifyMap(calib.left.K, calib.left.D, R1, P1, size, cv2.CV_32FC1)
    m2 = cv2.initUndistortRectifyMap(calib.right.K, calib.right.D, R2, P2, size, cv2.CV_32FC1)
    return Rectification(calib, R1, R2, P1, P2, Q, (m1[0], m1[1], m2[0], m2[1]))
