"""Systematic errors of the vision chain: the stereo calibration and the camera mount.

A pose from stereo vision is only as good as the calibration it is computed
with. Two errors stay fixed for a whole run (drawn once from the run's seed,
stream ``vision_calibration``) and so do not average out over detections:

* **stereo calibration** (:class:`StereoBias`): the detector believes focal
  lengths, principal points and the right camera's pose that differ from the
  real rig's by ``vision.calib_focal_rel_std`` (relative, per camera),
  ``vision.calib_principal_px_std`` (px, per coordinate and camera, at
  ``vision.image_width`` x ``vision.image_height``),
  ``vision.calib_stereo_rot_std_rad`` (per axis) and
  ``vision.calib_stereo_trans_std_m`` (per axis). A point seen by the real
  cameras is triangulated with the believed ones (:meth:`StereoBias.apparent`):
  the error grows with range (a disparity error of a fraction of a pixel is a
  depth error proportional to the range squared) and depends on where the
  point lies in the image, as a real rig's does;
* **camera mount** (:func:`mount_error`): the pose of the stereo rig relative
  to the arm's base (the hand-eye calibration, and the arm's own kinematic
  calibration folded in) is off by ``vision.mount_rot_std_rad`` per axis and
  ``vision.mount_trans_std_m`` per axis.

Both models use them: the table model (:mod:`sim_backend.vision`) moves the
true grasp frame's origin and a point on its axis through :meth:`StereoBias.apparent`
and the mount error; the rendered model (:mod:`sim_backend.vision_rendered`)
renders with the true rig and detects with :meth:`StereoBias.believed`. Every
standard deviation at zero gives the exact calibration (the previous behaviour).
Where the default numbers come from: ``sim_backend/scenarios/pool_clear.yaml``.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import numpy as np

from vision.calibration import CameraModel, StereoCalibration, load_stereo_calibration

from .geometry import _EYE4, norm, rotation_from_vector
from .render_cases import default_calibration
from .rng import child_rng

#: Scenario keys of this module, in draw order.
CALIBRATION_KEYS = (
    "vision.calib_focal_rel_std",
    "vision.calib_principal_px_std",
    "vision.calib_stereo_rot_std_rad",
    "vision.calib_stereo_trans_std_m",
    "vision.mount_rot_std_rad",
    "vision.mount_trans_std_m",
)


def _perturbed_camera(cam: CameraModel, rng: np.random.Generator, focal_rel: float, principal_px: float) -> CameraModel:
    K = cam.K.copy()
    f = 1.0 + focal_rel * float(rng.standard_normal())
    K[0, 0] *= f
    K[1, 1] *= f
    K[0, 2] += principal_px * float(rng.standard_normal())
    K[1, 2] += principal_px * float(rng.standard_normal())
    return CameraModel(cam.width, cam.height, K, cam.D.copy(), cam.name, cam.model)


@dataclass(frozen=True)
class StereoBias:
    """The real rig (``true``) and the calibration the detector uses (``believed``)."""

    true: StereoCalibration
    believed: StereoCalibration

    @classmethod
    def draw(cls, true: StereoCalibration, params: dict, rng: np.random.Generator) -> StereoBias:
        """One run's calibration errors (see the module docstring); all zero = exact."""
        f = float(params["vision.calib_focal_rel_std"])
        pp = float(params["vision.calib_principal_px_std"])
        rot = float(params["vision.calib_stereo_rot_std_rad"])
        trans = float(params["vision.calib_stereo_trans_std_m"])
        left = _perturbed_camera(true.left, rng, f, pp)
        right = _perturbed_camera(true.right, rng, f, pp)
        dR = rotation_from_vector(rot * rng.standard_normal(3))
        T = true.T + trans * rng.standard_normal(3)
        return cls(true, StereoCalibration(left, right, dR @ true.R, T, true.source + " (with calibration errors)"))

    @property
    def exact(self) -> bool:
        """True when the believed calibration is the real one."""
        b, t = self.believed, self.true
        return (
            np.array_equal(b.left.K, t.left.K)
            and np.array_equal(b.right.K, t.right.K)
            and np.array_equal(b.R, t.R)
            and np.array_equal(b.T, t.T)
        )

    @cached_property
    def triangulation_matrices(self) -> tuple[np.ndarray, ...]:
        """Matrices of :meth:`apparent`, computed once per run: ``(Kl^T, R^T, T, Kr^T, Kl^-T, Kr^-T R, c_r)``
        (the real cameras' K and stereo pose; the believed ones' inverse K, and the believed
        right camera centre in the left frame)."""
        t, b = self.true, self.believed
        cr = -b.R.T @ b.T  # believed right camera centre in the left frame
        return (
            t.left.K.T.copy(),
            t.R.T.copy(),
            t.T.copy(),
            t.right.K.T.copy(),
            np.linalg.inv(b.left.K).T.copy(),
            (np.linalg.inv(b.right.K).T @ b.R).copy(),
            cr,
        )

    def apparent(self, points_cam: np.ndarray) -> np.ndarray:
        """Where the detector puts points (k, 3) of the real left camera frame (m):
        projected by the real cameras (pinhole; the lens distortion is taken as
        known), triangulated with the believed ones (midpoint of the two rays).
        Returns (k, 3) in the believed left camera frame."""
        P = np.atleast_2d(np.asarray(points_cam, dtype=float))
        KlT, RT, T, KrT, KlinvT, KrinvT_R, cr = self.triangulation_matrices
        uvl = P.dot(KlT)
        uvl /= uvl[:, 2:3]  # homogeneous pixels [u v 1]
        uvr = (P.dot(RT) + T).dot(KrT)
        uvr /= uvr[:, 2:3]
        dl = uvl.dot(KlinvT)
        dr = uvr.dot(KrinvT_R)  # right rays in the left frame (R^T K^-1 [u v 1])
        # closest points of the rays s dl and cr + u dr
        a11 = np.einsum("ij,ij->i", dl, dl)
        a12 = -np.einsum("ij,ij->i", dl, dr)
        a22 = np.einsum("ij,ij->i", dr, dr)
        r1 = dl.dot(cr)
        r2 = -(dr.dot(cr))
        det = a11 * a22 - a12 * a12
        det = np.where(np.abs(det) < 1e-15, 1e-15, det)
        s = (r1 * a22 - a12 * r2) / det
        u = (a11 * r2 - a12 * r1) / det
        return 0.5 * (s[:, None] * dl + (cr + u[:, None] * dr))

    def apparent_pose(self, cam_T_grasp: np.ndarray, axis_span_m: float = 0.3) -> np.ndarray:
        """The grasp frame (4, 4, real camera frame) as the believed calibration sees it
        (believed camera frame): its origin and a point ``axis_span_m`` along its x
        axis (the pipe axis) are triangulated; z stays along the true z projected
        normal to the new axis (MARIS takes the rotation about the axis from gravity,
        which the calibration does not touch)."""
        o = cam_T_grasp[:3, 3]
        x = cam_T_grasp[:3, 0]
        q = self.apparent(np.array([o, o + axis_span_m * x]))
        x2 = q[1] - q[0]
        x2 /= norm(x2)
        z = cam_T_grasp[:3, 2]
        z2 = z - z.dot(x2) * x2
        n = norm(z2)
        z2 = z2 / n if n > 1e-9 else z
        out = _EYE4.copy()  # np.eye(4), cheaper
        out[:3, 0] = x2
        # z2 x x2 (the products and differences of np.cross, on floats: the same numbers, faster)
        a0, a1, a2 = z2.tolist()
        b0, b1, b2 = x2.tolist()
        out[:3, 1] = (a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0)
        out[:3, 2] = z2
        out[:3, 3] = q[0]
        return out


def mount_error(params: dict, rng: np.random.Generator) -> np.ndarray:
    """``true_camera_T_believed_camera`` (4, 4): how far the camera really is from
    where the arm's model puts it (rotation ``vision.mount_rot_std_rad`` per axis,
    translation ``vision.mount_trans_std_m`` per axis)."""
    out = np.eye(4)
    out[:3, :3] = rotation_from_vector(float(params["vision.mount_rot_std_rad"]) * rng.standard_normal(3))
    out[:3, 3] = float(params["vision.mount_trans_std_m"]) * rng.standard_normal(3)
    return out


@dataclass(frozen=True)
class VisionErrors:
    """One run's systematic vision errors: the stereo bias and the mount error."""

    stereo: StereoBias
    mount: np.ndarray

    @classmethod
    def draw(cls, params: dict, rng: np.random.Generator) -> VisionErrors:
        """Draw both from ``rng`` (the run's ``vision_calibration`` stream), for the
        scenario's rig (:func:`sim_backend.render_cases.default_calibration` at the
        scenario's image size and baseline, or its ``vision.calibration`` file)."""
        true = rig_calibration(params)
        stereo = StereoBias.draw(true, params, rng)
        return cls(stereo, mount_error(params, rng))

    def measured_vehicle_pose(self, vehicle_T_camera: np.ndarray, cam_T_grasp: np.ndarray) -> np.ndarray:
        """The grasp frame in the vehicle frame (4, 4) as the vision chain reports it,
        before its per-image noise: stereo bias, then the believed camera mount."""
        cam_pose = self.stereo.apparent_pose(cam_T_grasp)
        return vehicle_T_camera.dot(self.mount).dot(cam_pose)

    def correct_detection(self, vehicle_T_camera: np.ndarray, vehicle_T_grasp: np.ndarray) -> np.ndarray:
        """A detection the detector made with the URDF's camera mount (4, 4, vehicle
        frame), moved by the mount error (the rendered model's images already carry
        the stereo bias through :attr:`StereoBias.believed`)."""
        return vehicle_T_camera @ self.mount @ np.linalg.inv(vehicle_T_camera) @ vehicle_T_grasp


def rig_calibration(params: dict) -> StereoCalibration:
    """The scenario's real stereo rig (the rendered model's, also used by the table model)."""

    w, h = int(params["vision.image_width"]), int(params["vision.image_height"])
    path = params["vision.calibration"]
    if path:
        calib = load_stereo_calibration(path)
        if calib.left.size != (w, h):
            calib = calib.scaled(w / calib.left.width, h / calib.left.height)
        return calib
    return default_calibration(w, h, float(params["vision.baseline_m"]))


def run_errors(params: dict, seed: int) -> VisionErrors | None:
    """The run's systematic vision errors (stream ``vision_calibration`` of ``seed``),
    or None when every standard deviation is zero (an exact calibration)."""

    if not any(float(params[k]) > 0.0 for k in CALIBRATION_KEYS):
        return None
    return VisionErrors.draw(params, child_rng(seed, "vision_calibration"))
