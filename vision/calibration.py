"""Stereo calibration: camera models, files in the formats people already have.

Frames and units: a camera frame is OpenCV's optical frame (x right, y down, z
along the optical axis), metres. Pixels are (u, v) = (column, row) with the
centre of the top-left pixel at (0, 0). The stereo extrinsics follow OpenCV's
``stereoCalibrate``: a point ``X_l`` in the left camera frame is
``X_r = R @ X_l + T`` in the right camera frame (so a right camera to the
right of the left one has ``T ~ [-baseline, 0, 0]``). The left camera frame is
the rig's frame: it is the URDF ``stereo_camera`` frame of :mod:`kcl.model`.
Reading and writing the files: :mod:`vision.calibration_io` (re-exported here).

Files read by :func:`load_stereo_calibration`:

* OpenCV ``FileStorage`` YAML, XML or JSON stereo files (as written by
  ``cv::FileStorage``, e.g. by OpenCV's ``stereo_calib`` sample): one file with
  both cameras, or its ``intrinsics`` + ``extrinsics`` pair. Key names as
  common tools write them: ``M1``/``K1``/``cameraMatrix1``/``camera_matrix_left``,
  ``D1``/``dist1``/``distCoeffs1``/``distortion_coefficients_left`` (2 / right
  for the right camera), ``R``, ``T``; image size as ``image_width`` +
  ``image_height``, ``imageSize`` / ``image_size`` ([w, h]) or ``width`` + ``height``.
* Two per-camera OpenCV files (OpenCV's ``calibration`` sample: ``camera_matrix``,
  ``distortion_coefficients``, ``image_width``, ``image_height``), the right
  one holding ``R`` and ``T``.
* ROS ``camera_info`` YAML (``camera_calibration``'s output), one file per
  camera: ``image_width``, ``image_height``, ``camera_matrix``,
  ``distortion_coefficients``, ``rectification_matrix``, ``projection_matrix``.
  The stereo extrinsics follow from the rectifications and the right camera's
  projection matrix (its ``P[0, 3] = -fx' * baseline``).
* A Kalibr ``camchain.yaml``: ``cam0`` (left) and ``cam1`` (right), pinhole,
  ``radtan`` or ``equidistant`` (OpenCV's fisheye model), ``cam1.T_cn_cnm1``
  the right camera's ``R``, ``T``.

A camera without distortion coefficients is an error naming the keys looked
for, unless the file says ``distortion: none``: a missing distortion is never
taken as zero.

Every problem raises :class:`maris_common.yamlsrc.ConfigError` naming the file,
the line where the field is written, and the field.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

#: Distortion vector lengths OpenCV accepts (plumb bob / rational / thin prism / tilted).
DISTORTION_LENGTHS = (0, 4, 5, 8, 12, 14)


#: Lens models: OpenCV's radial-tangential (plumb bob, rational, thin prism) and
#: its fisheye model (equidistant: Kalibr's ``equidistant``, ROS's ``equidistant``).
LENS_MODELS = ("radtan", "equidistant")


@dataclass(frozen=True)
class CameraModel:
    """Pinhole camera with OpenCV distortion.

    width, height: image size (px). K: (3, 3) intrinsics (px). D: distortion
    coefficients; ``model`` ``radtan``: (k1, k2, p1, p2[, k3[, k4, k5, k6 ...]]),
    empty for none; ``equidistant``: OpenCV's fisheye (k1, k2, k3, k4).
    """

    width: int
    height: int
    K: np.ndarray
    D: np.ndarray = field(default_factory=lambda: np.zeros(5))
    name: str = ""
    model: str = "radtan"

    @property
    def size(self) -> tuple[int, int]:
        """(width, height) in pixels, OpenCV's order."""
        return (self.width, self.height)

    @property
    def fov(self) -> tuple[float, float]:
        """Full horizontal and vertical fields of view (rad) of the pinhole part."""
        fx, fy, cx, cy = self.K[0, 0], self.K[1, 1], self.K[0, 2], self.K[1, 2]
        h = np.arctan2(cx + 0.5, fx) + np.arctan2(self.width - cx - 0.5, fx)
        v = np.arctan2(cy + 0.5, fy) + np.arctan2(self.height - cy - 0.5, fy)
        return float(h), float(v)

    def scaled(self, sx: float, sy: float | None = None) -> CameraModel:
        """The same camera for images resized by ``sx`` (and ``sy``), e.g. 0.5 for half size.

        Pixel-centre convention: ``u' = sx * (u + 0.5) - 0.5``."""
        sy = sx if sy is None else sy
        K = self.K.copy()
        K[0, 0] *= sx
        K[0, 1] *= sx
        K[1, 1] *= sy
        K[0, 2] = sx * (K[0, 2] + 0.5) - 0.5
        K[1, 2] = sy * (K[1, 2] + 0.5) - 0.5
        return CameraModel(
            int(round(self.width * sx)), int(round(self.height * sy)), K, self.D.copy(), self.name, self.model
        )


@dataclass(frozen=True)
class StereoCalibration:
    """Two cameras and the pose of the right one: ``X_r = R @ X_l + T`` (m)."""

    left: CameraModel
    right: CameraModel
    R: np.ndarray
    T: np.ndarray
    source: str = ""

    @property
    def baseline(self) -> float:
        """Distance between the optical centres (m)."""
        return float(np.linalg.norm(self.T))

    @property
    def right_centre_in_left(self) -> np.ndarray:
        """Optical centre (3,) of the right camera in the left camera frame (m)."""
        return -self.R.T @ self.T

    def scaled(self, sx: float, sy: float | None = None) -> StereoCalibration:
        """The calibration for images resized by ``sx`` (and ``sy``)."""
        return StereoCalibration(self.left.scaled(sx, sy), self.right.scaled(sx, sy), self.R, self.T, self.source)

    def to_dict(self) -> dict:
        """JSON-able summary (K, D, R, T, sizes)."""
        cam = lambda c: {"width": c.width, "height": c.height, "K": c.K.tolist(), "D": c.D.tolist(), "model": c.model}  # noqa: E731
        return {
            "left": cam(self.left),
            "right": cam(self.right),
            "R": self.R.tolist(),
            "T": self.T.tolist(),
            "baseline_m": self.baseline,
            "source": self.source,
        }


def ideal_stereo(
    width: int,
    height: int,
    fov_h: float,
    baseline: float,
    *,
    distortion: tuple[float, ...] = (),
    right_rotation_rpy: tuple[float, float, float] = (0.0, 0.0, 0.0),
) -> StereoCalibration:
    """A nominal rig: square pixels, principal point at the centre, the right
    camera ``baseline`` m to the right (+x), optionally a little rotated."""
    fx = 0.5 * width / np.tan(0.5 * fov_h)
    K = np.array([[fx, 0.0, 0.5 * (width - 1)], [0.0, fx, 0.5 * (height - 1)], [0.0, 0.0, 1.0]])
    D = np.array(distortion, dtype=float) if distortion else np.zeros(5)
    r, p, y = right_rotation_rpy
    R = _rot_z(y) @ _rot_y(p) @ _rot_x(r)
    T = -R @ np.array([baseline, 0.0, 0.0])
    return StereoCalibration(
        CameraModel(width, height, K, D, "left"),
        CameraModel(width, height, K.copy(), D.copy(), "right"),
        R,
        T,
        f"ideal {width}x{height}, fov {fov_h:.3f} rad, baseline {baseline} m",
    )


def _rot_x(a: float) -> np.ndarray:
    c, s = np.cos(a), np.sin(a)
    return np.array([[1, 0, 0], [0, c, -s], [0, s, c]])


def _rot_y(a: float) -> np.ndarray:
    c, s = np.cos(a), np.sin(a)
    return np.array([[c, 0, s], [0, 1, 0], [-s, 0, c]])


def _rot_z(a: float) -> np.ndarray:
    c, s = np.cos(a), np.sin(a)
    return np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]])


_UNDISTORT_CRITERIA = (3, 30, 1e-10)  # cv2.TERM_CRITERIA_COUNT | EPS: converge, not OpenCV's default 5 steps


def undistort_points(pts: np.ndarray, cam: CameraModel, pixels: bool = False) -> np.ndarray:
    """Undistorted coordinates (k, 2) of raw pixel points ``pts`` (k, 2):
    normalized (``x = X/Z, y = Y/Z``), or undistorted pixels with ``pixels=True``."""
    import cv2  # only for OpenCV files and lens models: a HAL config loads without OpenCV

    src = np.asarray(pts, dtype=np.float64).reshape(-1, 1, 2)
    if len(src) == 0:
        return np.zeros((0, 2))
    P = cam.K if pixels else None
    if cam.model == "equidistant":
        return cv2.fisheye.undistortPoints(src, cam.K, cam.D, R=None, P=P, criteria=_UNDISTORT_CRITERIA).reshape(-1, 2)
    return cv2.undistortPoints(src, cam.K, cam.D, None, None, P, _UNDISTORT_CRITERIA).reshape(-1, 2)


def project_points(X: np.ndarray, cam: CameraModel) -> np.ndarray:
    """Raw (distorted) pixels (k, 2) of points ``X`` (k, 3) in the camera's frame (in front of it)."""
    import cv2  # only for OpenCV files and lens models: a HAL config loads without OpenCV

    src = np.asarray(X, dtype=np.float64).reshape(-1, 1, 3)
    if len(src) == 0:
        return np.zeros((0, 2))
    if cam.model == "equidistant":
        uv, _ = cv2.fisheye.projectPoints(src, np.zeros(3), np.zeros(3), cam.K, cam.D)
    else:
        uv, _ = cv2.projectPoints(src, np.zeros(3), np.zeros(3), cam.K, cam.D)
    return uv.reshape(-1, 2)


# the file formats (at the end: vision.calibration_io uses the classes above)
from vision.calibration_io import load_stereo_calibration, save_stereo_calibration  # noqa: E402

__all__ = [
    "CameraModel",
    "StereoCalibration",
    "ideal_stereo",
    "undistort_points",
    "project_points",
    "LENS_MODELS",
    "load_stereo_calibration",
    "save_stereo_calibration",
    "DISTORTION_LENGTHS",
]
