"""The MARIS stereo pipe detector: an image pair in, the pipe's grasp frame out.

``PipeDetector(calib, config).detect(left, right, gravity_cam=..., arm_masks=...,
vehicle_T_camera=...)`` runs, on raw BGR images of the calibrated size:

1. per image: colour region and straight edges (:mod:`vision.silhouette`),
   with the arm's pixels masked out;
2. the cylinder axis from the tangent planes of the edges of both cameras
   (:mod:`vision.cylinder`), the pipe radius as a prior;
3. the visible pipe end(s) along that axis, fitted to the end outlines;
4. the grasp frame: origin ``grasp_from_end_m`` from the visible end along the
   axis (the centre by default; with both ends in view, measured from their
   midpoint), x along the axis, z along gravity (the AHRS) orthogonal to it,
   so the rotation about the axis comes from gravity as in MARIS.

It returns a :class:`PipeDetection` (never raises for what is in the images:
no pipe in view is a detection with ``confidence == 0`` and a ``reason``).
Images that cannot be used (missing, empty, wrong size) raise
:class:`vision.errors.VisionInputError`.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np

from vision.calibration import StereoCalibration, undistort_points
from vision.cylinder import (
    AxisFit,
    closest_point_on_axis,
    fit_axis,
    fit_end,
    grasp_rotation,
    plane_from_line,
    rim_point_distances,
)
from vision.errors import VisionInputError
from vision.occlusion import ArmShape
from vision.refine import Observations, refine
from vision.silhouette import HsvRange, Silhouette, analyse, hsv_mask, select_region

#: Precision (px) of a fitted straight edge, for the expected depth error in the confidence.
EDGE_SIGMA_PX = 0.1
#: Expected position error (m) at which the geometry factor of the confidence is 0.5.
POSITION_SCALE_M = 0.01


@dataclass(frozen=True)
class DetectorConfig:
    """Detector settings; lengths in m, pixel sizes for the calibrated resolution."""

    hsv: HsvRange = HsvRange()
    pipe_radius_m: float = 0.05
    pipe_length_m: float = 1.0
    #: grasp-frame origin along the axis from the visible end (None: half the length, the centre)
    grasp_from_end_m: float | None = None
    #: weight of the known radius in the axis fit (1: like one tangent plane; 0: stereo only)
    radius_prior_weight: float = 1.0
    #: smallest colour region, as a fraction of the image area
    min_area_fraction: float = 2e-4
    #: straight edges with a larger rms residual (px) are not edges of a cylinder
    max_limb_rms_px: float = 2.0
    #: refine axis, radius and ends jointly against all edge points of both images
    refine: bool = True
    arm: ArmShape = ArmShape()

    @property
    def grasp_offset(self) -> float:
        return 0.5 * self.pipe_length_m if self.grasp_from_end_m is None else float(self.grasp_from_end_m)

    def check(self) -> list[str]:
        errs = list(self.hsv.check())
        if not 0.0 < self.pipe_radius_m < 1.0:
            errs.append(f"pipe radius must be in (0, 1) m, got {self.pipe_radius_m}")
        if not 0.0 < self.pipe_length_m < 20.0:
            errs.append(f"pipe length must be in (0, 20) m, got {self.pipe_length_m}")
        if self.grasp_from_end_m is not None and not 0.0 <= self.grasp_from_end_m <= self.pipe_length_m:
            errs.append(f"grasp_from_end_m must be within the pipe length, got {self.grasp_from_end_m}")
        return errs


@dataclass
class PipeDetection:
    """One detection, left camera frame (OpenCV optical frame, m) unless stated.

    confidence: 0 (nothing usable) .. 1. reason: why the confidence is low or 0.
    cam_T_grasp: (4, 4) grasp frame. end_cam: (3,) centre of the visible pipe end
    used for the origin (cTl in MARIS), None if no end was visible.
    vehicle_T_grasp: (4, 4) in the vehicle frame (vTg) when the camera mounting was given.
    """

    confidence: float
    reason: str = ""
    cam_T_grasp: np.ndarray | None = None
    end_cam: np.ndarray | None = None
    vehicle_T_grasp: np.ndarray | None = None
    axis_point_cam: np.ndarray | None = None
    axis_dir_cam: np.ndarray | None = None
    radius_m: float | None = None
    ends_cam: list = field(default_factory=list)
    views: dict = field(default_factory=dict)
    quality: dict = field(default_factory=dict)
    elapsed_ms: float = 0.0

    @property
    def found(self) -> bool:
        return self.confidence > 0.0 and self.cam_T_grasp is not None

    def to_dict(self) -> dict:
        """JSON-able form (poses as nested lists)."""
        arr = lambda a: None if a is None else np.asarray(a).tolist()  # noqa: E731
        return {
            "confidence": self.confidence,
            "reason": self.reason,
            "cam_T_grasp": arr(self.cam_T_grasp),
            "vehicle_T_grasp": arr(self.vehicle_T_grasp),
            "end_cam": arr(self.end_cam),
            "axis_point_cam": arr(self.axis_point_cam),
            "axis_dir_cam": arr(self.axis_dir_cam),
            "radius_m": self.radius_m,
            "ends_cam": [arr(e) for e in self.ends_cam],
            "views": self.views,
            "quality": self.quality,
            "elapsed_ms": self.elapsed_ms,
        }


def check_pair(left: np.ndarray | None, right: np.ndarray | None) -> None:
    """Raise :class:`VisionInputError` unless both are non-empty BGR images of one size."""
    for name, img in (("left", left), ("right", right)):
        if img is None:
            raise VisionInputError(f"{name} image: missing (no frame)")
        if not isinstance(img, np.ndarray) or img.size == 0:
            raise VisionInputError(f"{name} image: empty or corrupt frame")
        if img.ndim != 3 or img.shape[2] != 3 or img.dtype != np.uint8:
            raise VisionInputError(
                f"{name} image: expected an 8-bit colour (BGR) image, got shape {img.shape} {img.dtype}"
            )
    assert left is not None and right is not None
    if left.shape != right.shape:
        raise VisionInputError(
            f"image sizes differ: left {left.shape[1]}x{left.shape[0]}, right {right.shape[1]}x{right.shape[0]}"
        )


def calibration_for(calib: StereoCalibration, width: int, height: int) -> StereoCalibration:
    """``calib`` for images of ``width`` x ``height``: itself, or scaled when the
    images are a resized version (same aspect ratio); otherwise VisionInputError."""
    cw, ch = calib.left.size
    if (cw, ch) == (width, height):
        return calib
    sx, sy = width / cw, height / ch
    if abs(sx - sy) > 2.0 / min(cw, ch):
        raise VisionInputError(
            f"images are {width}x{height} but the calibration is for {cw}x{ch} (a different aspect ratio)"
        )
    return calib.scaled(sx, sy)


class PipeDetector:
    """Stateless detector for one calibration (precomputes what it can)."""

    def __init__(self, calib: StereoCalibration, config: DetectorConfig = DetectorConfig()):
        errs = config.check()
        if errs:
            raise ValueError("detector config: " + "; ".join(errs))
        self.calib = calib
        self.config = config
        self._scaled: dict[tuple[int, int], StereoCalibration] = {}

    def _calib(self, w: int, h: int) -> StereoCalibration:
        c = self._scaled.get((w, h))
        if c is None:
            c = self._scaled[(w, h)] = calibration_for(self.calib, w, h)
        return c

    def masks(
        self, left: np.ndarray, right: np.ndarray, arm_masks: tuple[np.ndarray, np.ndarray] | None = None
    ) -> tuple[list, list]:
        """Colour masks (with the arm removed) and arm 'blocked' masks of both images."""
        import cv2

        h, w = left.shape[:2]
        k = 3 if w < 1000 else 5
        kernel = cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (k, k))
        colour, blocked = [], []
        for i, img in enumerate((left, right)):
            m = hsv_mask(img, self.config.hsv)
            b = None
            if arm_masks is not None and arm_masks[i] is not None:
                arm = arm_masks[i]
                if arm.shape != m.shape:
                    raise VisionInputError(
                        f"arm mask {i}: size {arm.shape[::-1]} differs from the image's {m.shape[::-1]}"
                    )
                m = cv2.bitwise_and(m, cv2.bitwise_not(arm))
                b = cv2.dilate(arm, kernel, iterations=2)
            m = cv2.morphologyEx(m, cv2.MORPH_OPEN, kernel)
            colour.append(m)
            blocked.append(b)
        return colour, blocked

    def detect(
        self,
        left: np.ndarray,
        right: np.ndarray,
        *,
        gravity_cam: np.ndarray | None = None,
        arm_masks: tuple[np.ndarray, np.ndarray] | None = None,
        vehicle_T_camera: np.ndarray | None = None,
    ) -> PipeDetection:
        """Detect the pipe in a raw BGR pair. ``gravity_cam``: unit down vector in the
        left camera frame (from the AHRS); ``arm_masks``: uint8 masks (255 = arm)
        per image; ``vehicle_T_camera``: (4, 4) left camera pose in the vehicle frame."""
        t0 = time.perf_counter()
        check_pair(left, right)
        h, w = left.shape[:2]
        calib = self._calib(w, h)
        cfg = self.config
        min_area = max(12, int(cfg.min_area_fraction * w * h))
        colour, blocked = self.masks(left, right, arm_masks)
        cams = [(calib.left, np.eye(3), np.zeros(3)), (calib.right, calib.R, calib.T)]
        sils: list[Silhouette | None] = []
        views: dict = {}
        for name, img, m, b, (cam, _, _) in zip(("left", "right"), (left, right), colour, blocked, cams):
            region, why = select_region(m, min_area)
            sil = None if region is None else analyse(region, cam, b, img, max_limb_rms_px=cfg.max_limb_rms_px)
            sils.append(sil)
            views[name] = sil.to_dict() if sil is not None else {"reason": why}
        det = self._fit(sils, cams, calib, gravity_cam, vehicle_T_camera)
        det.views = views
        det.elapsed_ms = (time.perf_counter() - t0) * 1e3
        return det

    # ------------------------------------------------------------------ geometry

    def _fit(self, sils: list, cams: list, calib: StereoCalibration, gravity_cam, vehicle_T_camera) -> PipeDetection:
        cfg = self.config
        planes = []
        for j, (sil, (cam, R, t)) in enumerate(zip(sils, cams)):
            if sil is None or len(sil.limbs) < 2:
                continue
            inside = undistort_points(sil.centroid, cam)[0]
            ray = np.append(inside, 1.0)
            for limb in sil.limbs[:2]:
                planes.append(plane_from_line(limb.line_norm, R, t, ray, j))
        if not planes:
            reasons = [v for v in (s.reason if s is not None else "no pipe-coloured region" for s in sils)]
            return PipeDetection(0.0, "no pipe in view: " + "; ".join(dict.fromkeys(r for r in reasons if r)))
        fit = fit_axis(planes, cfg.pipe_radius_m, cfg.radius_prior_weight)
        if fit is None:
            return PipeDetection(0.0, "the straight edges do not fix a cylinder axis")
        if fit.r <= 0 or not np.all(np.isfinite(fit.p)) or fit.p @ fit.p > 100.0 or _depth(fit) <= 0.05:
            return PipeDetection(
                0.0, f"implausible cylinder fit (radius {fit.r:.3f} m, {float(np.linalg.norm(fit.p)):.2f} m away)"
            )
        ends, end_rms, outlines = self._ends(fit, sils, cams)
        if cfg.refine:
            obs = [
                _observations(sil, cam, R, t, outlines.get(j, {}))
                for j, (sil, (cam, R, t)) in enumerate(zip(sils, cams))
                if sil is not None and sil.limbs
            ]
            new_fit, new_ends, rms = refine(fit, ends, obs, cfg.pipe_radius_m)
            if np.isfinite(rms) and rms < 3.0 and abs(new_fit.r - cfg.pipe_radius_m) < 0.6 * cfg.pipe_radius_m:
                fit, ends = new_fit, new_ends
                end_rms = [rms] * len(ends)
        centroid_s = self._centroid_s(fit, sils, cams)
        quality: dict = {
            "plane_rms_m": fit.plane_rms,
            "radius_m": fit.r,
            "views": fit.n_cameras,
            "limb_rms_px": [lb.rms_px for s in sils if s is not None for lb in s.limbs],
            "end_rms_px": end_rms,
        }
        reasons: list[str] = []
        off = cfg.grasp_offset
        if len(ends) >= 2:
            s_a, s_b = sorted(ends, key=lambda s: float(np.linalg.norm(fit.p + s * fit.a)))[:2]
            inward = np.sign(s_b - s_a) or 1.0
            grasp_s = 0.5 * (s_a + s_b) + inward * (off - 0.5 * cfg.pipe_length_m)
            length = abs(s_b - s_a)
            quality["length_m"] = length
            f_end = max(0.0, 1.0 - abs(length - cfg.pipe_length_m) / (0.5 * cfg.pipe_length_m))
            if f_end < 0.8:
                reasons.append(f"measured length {length:.2f} m differs from {cfg.pipe_length_m:.2f} m")
            end_s = s_a
        elif len(ends) == 1:
            end_s = ends[0]
            inward = np.sign(centroid_s - end_s) or 1.0
            grasp_s = end_s + inward * off
            f_end = 1.0
        else:
            end_s = None
            grasp_s = centroid_s
            f_end = 0.4
            reasons.append("no pipe end visible: the position along the axis is a guess")
        # axis sign: along the vehicle's forward axis (else starboard), so the tool turns the least
        a = fit.a.copy()
        ref = vehicle_T_camera[:3, :3].T if vehicle_T_camera is not None else np.eye(3)
        fwd, stbd = ref[:, 0], ref[:, 1]
        if a @ fwd < 0 or (abs(a @ fwd) < 0.2 and a @ stbd < 0):
            a = -a
        origin = fit.p + grasp_s * fit.a
        down = (
            np.array([0.0, 1.0, 0.0])
            if gravity_cam is None
            else np.asarray(gravity_cam, float) / np.linalg.norm(gravity_cam)
        )
        Rg, sin_g = grasp_rotation(a, down if gravity_cam is not None else None, np.array([0.0, 1.0, 0.0]))
        T = np.eye(4)
        T[:3, :3], T[:3, 3] = Rg, origin
        f_grav = 1.0 if sin_g >= 0.3 else 0.5
        if gravity_cam is None:
            f_grav = 0.8
            reasons.append("no gravity: rotation about the axis from the image's down direction")
        elif sin_g < 0.3:
            reasons.append("pipe nearly vertical: rotation about the axis from the image")
        rng = float(np.linalg.norm(origin))
        focal = float(calib.left.K[0, 0])
        plane_px = fit.plane_rms * focal / max(rng, 0.1)
        f_fit = 1.0 / (1.0 + (plane_px / 2.0) ** 2)
        f_radius = max(0.0, 1.0 - abs(fit.r - cfg.pipe_radius_m) / (0.6 * cfg.pipe_radius_m))
        limb_rms = max(quality["limb_rms_px"]) if quality["limb_rms_px"] else 0.0
        f_straight = 1.0 / (1.0 + (limb_rms / 1.5) ** 2)
        f_views = 1.0 if fit.n_cameras >= 2 else 0.6
        # depth precision: stereo along the baseline's part across the axis, plus the apparent width
        base = calib.right_centre_in_left
        across = float(np.linalg.norm(np.cross(fit.a, base))) if fit.n_cameras >= 2 else 0.0
        sigma_depth = rng * rng * EDGE_SIGMA_PX / (focal * float(np.hypot(across, 2.0 * fit.r)))
        f_geom = 1.0 / (1.0 + (sigma_depth / POSITION_SCALE_M) ** 2)
        if fit.n_cameras < 2:
            reasons.append("seen by one camera only: depth from the known radius")
        if f_radius < 0.5:
            reasons.append(f"fitted radius {fit.r:.3f} m is far from {cfg.pipe_radius_m:.3f} m")
        conf = float(np.clip(f_end * f_grav * f_fit * f_radius * f_straight * f_views * f_geom, 0.0, 1.0))
        quality.update(
            {
                "plane_rms_px": plane_px,
                "range_m": rng,
                "factors": {
                    "end": f_end,
                    "gravity": f_grav,
                    "fit": f_fit,
                    "radius": f_radius,
                    "straight": f_straight,
                    "views": f_views,
                    "geometry": f_geom,
                },
                "depth_sigma_m": sigma_depth,
            }
        )
        end_cam = None if end_s is None else fit.p + end_s * fit.a
        det = PipeDetection(
            conf,
            "; ".join(reasons),
            T,
            end_cam,
            None,
            fit.p,
            a,
            fit.r,
            [fit.p + s * fit.a for s in ends],
            quality=quality,
        )
        if vehicle_T_camera is not None:
            det.vehicle_T_grasp = np.asarray(vehicle_T_camera, float) @ T
        return det

    def _centroid_s(self, fit: AxisFit, sils: list, cams: list) -> float:
        vals = []
        for sil, (cam, R, t) in zip(sils, cams):
            if sil is None:
                continue
            xy = undistort_points(sil.centroid, cam)[0]
            origin = -R.T @ t
            vals.append(closest_point_on_axis(fit, origin, R.T @ np.append(xy, 1.0)))
        return float(np.mean(vals)) if vals else 0.0

    def _ends(self, fit: AxisFit, sils: list, cams: list) -> tuple[list[float], list[float], dict]:
        """Axis coordinates (m) of the visible pipe ends, the rms (px) of their fits,
        and the outline points kept for each (camera index -> {end index: (k, 2)}):
        points farther than ``max(1.5 px, 3 x median)`` from the fitted rim are
        dropped (e.g. a shading edge inside the pipe)."""
        found: list[tuple[float, list]] = []  # (s0, [(camera, R, t, pts, f)])
        for j, (sil, (cam, R, t)) in enumerate(zip(sils, cams)):
            if sil is None:
                continue
            origin = -R.T @ t
            for pts in sil.ends.values():
                c = pts.mean(axis=0)
                s0 = closest_point_on_axis(fit, origin, R.T @ np.append(c, 1.0))
                entry = (j, R, t, pts, float(cam.K[0, 0]))
                for group in found:
                    if abs(group[0] - s0) < 0.25 * self.config.pipe_length_m:
                        group[1].append(entry)
                        break
                else:
                    found.append((s0, [entry]))
        ends, rms = [], []
        kept: dict[int, dict[int, np.ndarray]] = {}
        for s0, group in found:
            cams_ = [e[1:] for e in group]
            s, _ = fit_end(fit, s0, 3.0 * fit.r + 0.02, cams_)
            clean = []
            for j, R, t, pts, f in group:
                d = rim_point_distances(fit, s, R, t, pts) * f
                keep = d <= max(1.5, 3.0 * float(np.median(d)))
                if keep.sum() >= 6:
                    clean.append((j, R, t, pts[keep], f))
            if not clean:
                continue
            s, r = fit_end(fit, s, 0.02, [e[1:] for e in clean])
            if np.isfinite(r) and r < 2.5:
                k = len(ends)
                ends.append(s)
                rms.append(r)
                for j, _, _, pts, _ in clean:
                    kept.setdefault(j, {})[k] = pts
        return ends, rms, kept


def _observations(sil: Silhouette, cam, R: np.ndarray, t: np.ndarray, ends: dict) -> Observations:
    """Edge points of one view in normalized coordinates, for :func:`vision.refine.refine`."""
    Kinv = np.linalg.inv(cam.K)
    norm = lambda P: (np.column_stack([P, np.ones(len(P))]) @ Kinv.T)[:, :2]  # noqa: E731 - undistorted px -> normalized
    return Observations(R, t, float(cam.K[0, 0]), [norm(lb.points) for lb in sil.limbs[:2]], ends)


def _depth(fit: AxisFit) -> float:
    return float(fit.p[2])
