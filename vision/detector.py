"""The MARIS stereo pipe detector: an image pair in, the pipe's grasp frame out.

``PipeDetector(calib, config).detect(left, right, gravity_cam=..., arm_masks=...,
vehicle_T_camera=...)`` runs, on raw BGR images of the calibrated size:

1. per image: colour restoration (:mod:`vision.colour`), colour region and
   straight edges (:mod:`vision.silhouette`), with the arm's pixels masked out;
2. the cylinder axis from the tangent planes of every usable edge of both
   cameras (:mod:`vision.cylinder`; weak edges when the geometry agrees), the
   pipe radius as a prior (:class:`PipeEngine`);
3. the visible pipe end(s) along that axis, fitted to the end outlines, then
   everything refined together (:mod:`vision.refine`, the pipe's length as a
   prior with two ends);
4. the grasp frame: origin ``grasp_from_end_m`` from the visible end along the
   axis (the centre by default; with both ends in view, measured from their
   midpoint), x along the axis, z along gravity (the AHRS) orthogonal to it,
   so the rotation about the axis comes from gravity as in MARIS; and a
   confidence meant as the chance that the grasp point is within 2 cm
   (docs/vision.md checks it on the evaluation set).

It returns a :class:`PipeDetection` (never raises for what is in the images:
no pipe in view is a detection with ``confidence == 0`` and a ``reason``).
Images that cannot be used (missing, empty, wrong size) raise
:class:`vision.errors.VisionInputError`.
"""

from __future__ import annotations

import copy
import itertools
import math
import time
from dataclasses import dataclass, field

import cv2
import numpy as np

from vision.calibration import CameraModel, StereoCalibration, project_points, undistort_points
from vision.colour import ColourRestoration, RestoredImage, correction
from vision.cylinder import (
    AxisFit,
    Plane,
    axis_from_one_camera,
    cap_faces_camera,
    closest_point_on_axis,
    fit_axis,
    fit_end,
    grasp_rotation,
    plane_from_line,
    rim_point_distances,
)
from vision.end_search import RimEnd, RimSearch, RimView, search_end
from vision.errors import VisionInputError
from vision.occlusion import ArmShape
from vision.refine import Observations, refine
from vision.silhouette import (
    EdgeSearch,
    HsvRange,
    Hysteresis,
    Limb,
    LocalContrast,
    Region,
    Silhouette,
    UnevenLight,
    analyse,
    colour_mask,
    contrast_mask,
    elongation,
    reduced_mask,
    select_region,
    upsampled_mask,
    upsampled_region,
)

#: Systematic error (px) of a fitted straight edge (shading, blur, compression), for the
#: expected depth error in the confidence; the edge points' own scatter adds to it.
EDGE_BIAS_PX = 0.25
#: The same for a fitted pipe end (its outline is short and curved).
END_BIAS_PX = 0.4
#: Edge points closer than this (px) along an edge are not independent (compression blocks).
CORRELATION_PX = 4
#: The grasp point's tolerance (m) the confidence is about: the geometry factor is the chance
#: that the expected depth error stays within it.
POSITION_TOLERANCE_M = 0.02
#: Two planes of one edge per camera fix an axis only when they are this far from parallel (the
#: sine of their angle; the axis direction's error is the planes' error over it).
MIN_PLANE_ANGLE = 0.03
#: The confidence factor of an axis from one edge in each camera (no redundancy at all).
ONE_EDGE_EACH_FACTOR = 0.6
#: The confidence factor per edge found from the colour against the local background (a faint
#: pipe in turbid water, :func:`vision.silhouette.contrast_mask`): its position is less sure
#: (block noise, the shaded side fading into the veil) on top of its being weak.
FAINT_EDGE_FACTOR = 0.85
#: The confidence factor of an axis from one camera's edges when the other camera, searched where
#: that cylinder projects, shows no edges that agree with it (the answer is likely not the pipe).
UNSEEN_FACTOR = 0.2
#: An axis from the two edges of one camera and one edge of the other disagreeing by more than
#: this (deg) with the axis those two edges fix alone (with the known radius) is suspect: the
#: single edge is all that turns it, and an answer that far off is wrong (the evaluation's
#: criterion); where the pipe lies along the baseline the two cameras' planes of one edge
#: nearly coincide and a small error of either tilts the axis in depth by many degrees.
MAX_ONE_CAMERA_DISAGREEMENT_DEG = 5.0
#: The confidence factor of such an axis.
DISAGREEMENT_FACTOR = 0.2
#: The confidence factor per end found along the rim of a ``2+1`` / ``1+2`` axis that a camera
#: in view of it does not confirm (:class:`RefusedEnd`): a true end is one point that every camera
#: sees where a right axis puts it, so such an end says the axis is off in depth there, as the
#: other camera's contradictions of a one-camera axis (:data:`DISAGREEMENT_FACTOR`,
#: :data:`UNSEEN_FACTOR`) say, and weighs as much.
REFUSED_END_FACTOR = 0.2
#: The confidence factor of an axis from one camera of a pair without an end, where the other
#: camera cannot look where that cylinder projects (mostly outside its view): neither the other
#: camera nor an end checks it, which leaves the monocular mode's answer with the position along
#: the axis a guess (with :data:`NO_END_FACTOR`, under the least reported confidence).
UNCHECKED_FACTOR = 0.5
#: The confidence factor without a pipe end in view (the position along the axis is the
#: colour region's centroid, often 10-30 cm off).
NO_END_FACTOR = 0.3


@dataclass(frozen=True)
class DetectorConfig:
    """Detector settings; lengths in m, pixel sizes for the calibrated resolution."""

    hsv: HsvRange = HsvRange()
    #: colour restoration before the colour region (grey world, as MARIS)
    colour: ColourRestoration = ColourRestoration()
    #: weak colour range joining the region where it touches the strong one
    hysteresis: Hysteresis = Hysteresis()
    #: without a colour region: the region from the colour's difference to the local background
    contrast: LocalContrast = LocalContrast()
    #: where the first look gives no answer it reports, the faint pipe looked for again under
    #: uneven light (the lamps' backscatter); None: no look again
    uneven: UnevenLight | None = UnevenLight()
    pipe_radius_m: float = 0.05
    pipe_length_m: float = 1.0
    #: grasp-frame origin along the axis from the visible end (None: half the length, the centre)
    grasp_from_end_m: float | None = None
    #: weight of the known radius in the axis fit (1: like one tangent plane; 0: stereo only)
    radius_prior_weight: float = 1.0
    #: smallest colour region, as a fraction of the image area
    min_area_fraction: float = 2e-4
    #: straight edges with a larger rms residual (px) are not edges of a cylinder
    max_limb_rms_px: float = 3.0
    #: the limb search across the region (edges outside the colour region, the width prior)
    edges: EdgeSearch = EdgeSearch()
    #: two ends whose distance differs from the pipe's length by this (m) lower the confidence to 1/e
    length_tolerance_m: float = 0.05
    #: an end outline fitting its rim worse than this (rms, px) is not an end
    max_end_rms_px: float = 4.0
    #: a weak edge joins when its plane is this close (px) to the cylinder of the others
    weak_edge_tolerance_px: float = 2.5
    #: weak edges alone are kept when the free radius of all planes is this close (share) to the pipe's
    weak_radius_tolerance: float = 0.2
    #: an answer less sure than this is reported as no pipe (confidence 0, no grasp frame; its fit
    #: and reason kept, its confidence and grasp frame in ``quality['confidence_unreported']`` and
    #: ``quality['cam_T_grasp_unreported']``): below it most answers are wrong, and every answer on
    #: a pipe-free view falls below it (docs/vision.md, the detector's step 9)
    min_reported_confidence: float = 0.2
    #: refine axis, radius and ends jointly against all edge points of both images
    refine: bool = True
    #: without an end from the outlines: the end searched along the fitted axis, its fall
    #: integrated along the rim's image (:mod:`vision.end_search`)
    rim_search: RimSearch = RimSearch()
    arm: ArmShape = ArmShape()

    @property
    def grasp_offset(self) -> float:
        return 0.5 * self.pipe_length_m if self.grasp_from_end_m is None else float(self.grasp_from_end_m)

    def check(self) -> list[str]:
        errs = list(self.hsv.check()) + self.colour.check() + (self.uneven.check() if self.uneven else [])
        if not 0.0 < self.pipe_radius_m < 1.0:
            errs.append(f"pipe radius must be in (0, 1) m, got {self.pipe_radius_m}")
        if not 0.0 < self.pipe_length_m < 20.0:
            errs.append(f"pipe length must be in (0, 20) m, got {self.pipe_length_m}")
        if not 0.0 <= self.min_reported_confidence < 1.0:
            errs.append(f"min_reported_confidence must be within [0, 1), got {self.min_reported_confidence}")
        if self.grasp_from_end_m is not None and not 0.0 <= self.grasp_from_end_m <= self.pipe_length_m:
            errs.append(f"grasp_from_end_m must be within the pipe length, got {self.grasp_from_end_m}")
        return errs


@dataclass(frozen=True)
class RefusedEnd:
    """An end found along the rim of a ``2+1`` / ``1+2`` axis and not taken: the cameras that
    do not confirm it on their own (:meth:`vision.end_search.RimEnd.unconfirmed`) and, of those,
    the ones that contradict it (:meth:`vision.end_search.RimEnd.contradicted_by`): in view of
    the end (their rim image there not cut by the image border or the arm, their colour region
    not running into either on that side), they place the end elsewhere along the axis."""

    end: RimEnd
    unconfirmed: list[int]
    contradicting: list[int]


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
    """Stereo detector for one calibration (precomputes what it can); the work on the
    views is :class:`PipeEngine`'s."""

    def __init__(self, calib: StereoCalibration, config: DetectorConfig = DetectorConfig()):
        self.engine = PipeEngine(config)
        self.calib = calib
        self._scaled: dict[tuple[int, int], StereoCalibration] = {}

    @property
    def config(self) -> DetectorConfig:
        return self.engine.config

    def _calib(self, w: int, h: int) -> StereoCalibration:
        c = self._scaled.get((w, h))
        if c is None:
            c = self._scaled[(w, h)] = calibration_for(self.calib, w, h)
        return c

    def restored(self, img: np.ndarray) -> np.ndarray:
        """``img`` after the configured colour restoration."""
        return self.engine.restored(img)

    def masks(
        self,
        left: np.ndarray | RestoredImage,
        right: np.ndarray | RestoredImage,
        arm_masks: tuple[np.ndarray, np.ndarray] | None = None,
    ) -> tuple[list, list]:
        """Colour masks (with the arm removed) and arm 'blocked' masks of both images
        (raw images are restored first, as :meth:`detect` does)."""
        return self.engine.masks_of([left, right], list(arm_masks) if arm_masks is not None else None)

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
        cams = [(calib.left, np.eye(3), np.zeros(3)), (calib.right, calib.R, calib.T)]
        masks: list[np.ndarray | None] | None = list(arm_masks) if arm_masks is not None else None
        det = self.engine.detect_views([("left", left), ("right", right)], cams, masks, gravity_cam, vehicle_T_camera)
        det.elapsed_ms = (time.perf_counter() - t0) * 1e3
        return det


class PipeEngine:
    """The detector's work on one or two views: colour restoration, colour region,
    edges, cylinder, ends, grasp frame and confidence (shared by :class:`PipeDetector`
    and :class:`vision.monocular.MonocularPipeDetector`)."""

    def __init__(self, config: DetectorConfig = DetectorConfig()):
        errs = config.check()
        if errs:
            raise ValueError("detector config: " + "; ".join(errs))
        self.config = config

    def restored(self, img: np.ndarray) -> np.ndarray:
        """``img`` after the configured colour restoration."""
        c = correction(img, self.config.colour)
        return img if c is None else c.apply(img)

    def masks_of(
        self, images: list[np.ndarray | RestoredImage], arm_masks: list[np.ndarray | None] | None
    ) -> tuple[list, list]:
        """Full-resolution colour masks (the arm removed) and the arm's 'blocked' masks
        (None without an arm mask) of the images, as the detector sees them."""
        colour, blocked = [], []
        for img, small, arm, _, b in self._reduced_masks(images, arm_masks):
            h, w = img.shape[:2]
            m = upsampled_mask(small, w, h)
            if arm is not None:
                m = cv2.bitwise_and(m, cv2.bitwise_not(arm))
            colour.append(m)
            blocked.append(b)
        return colour, blocked

    def _reduced_masks(
        self, images: list[np.ndarray | RestoredImage], arm_masks: list[np.ndarray | None] | None
    ) -> list[tuple[RestoredImage, np.ndarray, np.ndarray | None, np.ndarray | None, np.ndarray | None]]:
        """Per image: the restored image, its colour mask at the working resolution
        (:func:`vision.silhouette.colour_mask`; the arm removed, speckle opened away),
        the arm mask, the arm mask at the working resolution and the arm's 'blocked'
        mask (the arm dilated, full resolution)."""
        out = []
        for i, img in enumerate(images):
            if not isinstance(img, RestoredImage):
                img = RestoredImage(img, correction(img, self.config.colour))
            h, w = img.shape[:2]
            small = colour_mask(img, self.config.hsv, hysteresis=self.config.hysteresis)
            arm, arm_small, b = None, None, None
            if arm_masks is not None and arm_masks[i] is not None:
                arm = arm_masks[i]
                assert arm is not None
                if arm.shape != (h, w):
                    raise VisionInputError(f"arm mask {i}: size {arm.shape[::-1]} differs from the image's {(w, h)}")
                arm_small = reduced_mask(arm, small)
                k = 3 if w < 1000 else 5
                b = cv2.dilate(arm, cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (k, k)), iterations=2)
            out.append((img, self._cleaned(small, w, arm_small), arm, arm_small, b))
        return out

    @staticmethod
    def _cleaned(small: np.ndarray, width: int, arm_small: np.ndarray | None) -> np.ndarray:
        """A reduced colour mask without the arm's pixels (``arm_small``: the arm at the
        mask's resolution) and the speckle."""
        if arm_small is not None:
            small = cv2.bitwise_and(small, cv2.bitwise_not(arm_small))
        # speckle: what a 5 x 5 opening removes at 1292 px (3 x 3 at 646), at the mask's resolution
        k = max(2, int(round((3 if width < 1000 else 5) / (width / small.shape[1]))))
        return cv2.morphologyEx(small, cv2.MORPH_OPEN, cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (k, k)))

    def detect_views(
        self,
        images: list[tuple[str, np.ndarray]],
        cams: list[tuple[CameraModel, np.ndarray, np.ndarray]],
        arm_masks: list[np.ndarray | None] | None,
        gravity_cam: np.ndarray | None,
        vehicle_T_camera: np.ndarray | None,
    ) -> PipeDetection:
        """The detector on one or two views (camera ``j`` at ``X_j = R_j X + t_j``, the first the
        reference). Where the first look gives no answer it reports and a view's colour gave
        fewer than two edges, it looks again for a faint pipe under uneven light
        (``DetectorConfig.uneven``) and takes that answer when it is reported."""

        cfg = self.config
        h, w = images[0][1].shape[:2]
        min_area = max(12, int(cfg.min_area_fraction * w * h))
        restored = [RestoredImage(img, correction(img, cfg.colour)) for _, img in images]
        reduced = self._reduced_masks(list(restored), arm_masks)
        names = [name for name, _ in images]
        colour = [
            self._silhouette(small, img, arm, b, cam, min_area)
            for (img, small, arm, _, b), (cam, _, _) in zip(reduced, cams)
        ]
        look = (names, reduced, colour, cams, min_area, gravity_cam, vehicle_T_camera, restored)
        det = self._look(*look, None)
        faint_looked = cfg.contrast.enabled and any(sil is None or len(sil.limbs) < 2 for sil, _ in colour)
        if det.confidence < cfg.min_reported_confidence and faint_looked and cfg.uneven is not None:
            again = self._look(*look, cfg.uneven)
            if again.confidence >= cfg.min_reported_confidence and again.confidence > det.confidence:
                again.quality["uneven_light"] = True
                det = again
        if 0.0 < det.confidence < cfg.min_reported_confidence:
            # too unsure to be reported as the pipe: no pipe, the fit kept for diagnostics
            det.quality["confidence_unreported"] = det.confidence
            if det.cam_T_grasp is not None:
                det.quality["cam_T_grasp_unreported"] = det.cam_T_grasp.tolist()
            note = f"confidence {det.confidence:.2f} under the least reported ({cfg.min_reported_confidence:g}): not the pipe"
            det.reason = f"{det.reason}; {note}" if det.reason else note
            det.confidence = 0.0
            det.cam_T_grasp = det.vehicle_T_grasp = None
        return det

    def _look(
        self,
        names: list[str],
        reduced: list,
        colour: list[tuple[Silhouette | None, str]],
        cams: list[tuple[CameraModel, np.ndarray, np.ndarray]],
        min_area: int,
        gravity_cam: np.ndarray | None,
        vehicle_T_camera: np.ndarray | None,
        restored: list[RestoredImage],
        uneven: UnevenLight | None,
    ) -> PipeDetection:
        """One look at the views (``reduced``: :meth:`_reduced_masks`; ``colour``: their colour
        regions' silhouettes and why there is none, computed once for every look): where a
        colour region gives fewer than two edges, the colour against the background (from its
        smooth trend with ``uneven``), then the fit."""
        cfg = self.config
        sils: list[Silhouette | None] = []
        blocked: list[np.ndarray | None] = []
        views: dict = {}
        for name, (img, _, arm, arm_small, b), (found, why), (cam, _, _) in zip(names, reduced, colour, cams):
            sil = copy.copy(found)  # the fit sets its edges and ends: each look fits its own copy
            if (sil is None or len(sil.limbs) < 2) and cfg.contrast.enabled:
                # no pipe colour, or not enough of it for two edges: the colour against the background
                w = img.shape[1]
                faint = contrast_mask(img, cfg.hsv, cfg.contrast, cfg.hysteresis, uneven=uneven)
                rel = self._cleaned(faint, w, arm_small)
                sil2, why2 = self._silhouette(rel, img, arm, b, cam, min_area, cfg.contrast.min_elongation, uneven)
                if sil2 is not None and (sil is None or len(sil2.limbs) > len(sil.limbs)):
                    for lb in sil2.limbs:  # a faint pipe's edges: kept where the geometry agrees
                        lb.weak = lb.faint = True
                    sil, why = sil2, why2
            sils.append(sil)
            blocked.append(b)
            views[name] = sil.to_dict() if sil is not None else {"reason": why}
        det = self._fit(sils, cams, gravity_cam, vehicle_T_camera, blocked, restored)
        det.views = views
        return det

    def _silhouette(
        self,
        small: np.ndarray,
        img: RestoredImage,
        arm: np.ndarray | None,
        blocked: np.ndarray | None,
        cam: CameraModel,
        min_area: int,
        min_elongation: float = 0.0,
        uneven: UnevenLight | None = None,
    ) -> tuple[Silhouette | None, str]:
        """The pipe's region in a reduced mask, at full resolution without the arm, and its
        edges and ends (:func:`vision.silhouette.analyse`; ``uneven``: a faint pipe's region
        under uneven light); None and why without one (or when the region is less elongated
        than ``min_elongation``: its spread along its axis over its spread across)."""
        cfg = self.config
        h, w = img.shape[:2]
        scale = (w / small.shape[1]) * (h / small.shape[0])
        region, why = select_region(small, max(4, int(round(min_area / scale))))
        if region is None:
            return None, why
        if min_elongation > 0.0 and elongation(region.mask) < min_elongation:
            return None, "no pipe-shaped region"
        region = upsampled_region(region, w, h)
        if arm is not None:
            mh, mw = region.mask.shape
            part = arm[region.y0 : region.y0 + mh, region.x0 : region.x0 + mw]
            region = Region(
                cv2.bitwise_and(region.mask, cv2.bitwise_not(part)), region.x0, region.y0, (h, w), region.pixel
            )
        if cv2.countNonZero(region.mask) < min_area:
            return None, f"colour region too small (< {min_area} px)"
        sil = analyse(region, cam, blocked, img, max_limb_rms_px=cfg.max_limb_rms_px, search=cfg.edges, uneven=uneven)
        return sil, ""

    # ------------------------------------------------------------------ geometry

    def _planes(self, sils: list, cams: list) -> tuple[AxisFit | None, list[list[Limb]], str]:
        """The cylinder axis from every usable edge of both cameras, the edges it
        kept per camera, and why there is none.

        Edges fix an axis with the known radius when one camera has both (depth
        from the apparent width), or each camera one and their two planes are not
        nearly the same (the axis parallel to both, at the radius from each). The
        axis is fitted to the largest set of edges that agree on a cylinder in front
        of the cameras (:func:`_plausible`: a spurious edge can pull the fit of all
        behind them), the one with the fewest weak (low-contrast) edges among those
        of that size: a set with weak edges of both cameras agrees when every plane
        is within ``weak_edge_tolerance_px`` of the cylinder they fit and, where the two
        cameras' planes fix the radius (the pipe across the baseline, near enough),
        the radius they fit without the prior is the pipe's (within
        ``weak_radius_tolerance``): geometry consistent across the two cameras.
        Strong edges are taken as they are, and so are weak edges of one camera
        alone (the monocular mode, or the other camera seeing none): nothing to
        check them against, their factor in the confidence says so."""
        cfg = self.config
        cands: list[tuple[int, Limb, Plane]] = []
        for j, (sil, (cam, R, t)) in enumerate(zip(sils, cams)):
            if sil is None or not sil.limbs:
                continue
            ray = np.append(undistort_points(sil.centroid, cam)[0], 1.0)
            for limb in sil.limbs[:2]:
                cands.append((j, limb, plane_from_line(limb.line_norm, R, t, ray, j)))
        if not cands:
            reasons = [s.reason if s is not None else "no pipe-coloured region" for s in sils]
            return None, [[], []], "no pipe in view: " + "; ".join(dict.fromkeys(r for r in reasons if r))

        def usable(sel: list[tuple[int, Limb, Plane]]) -> bool:
            per = [sum(1 for j, _, _ in sel if j == k) for k in (0, 1)]
            if max(per) >= 2:
                return True
            # one edge per camera: their planes must not be (nearly) the same
            return per == [1, 1] and float(np.linalg.norm(np.cross(sel[0][2].n, sel[1][2].n))) >= MIN_PLANE_ANGLE

        def fit_of(sel: list[tuple[int, Limb, Plane]], prior: float) -> AxisFit | None:
            if not usable(sel):
                return None
            if len({j for j, _, _ in sel}) == 1 and len(sel) == 2:  # one camera: the closed form
                cam, R, t = cams[sel[0][0]]
                f = axis_from_one_camera(sel[0][2], sel[1][2], cfg.pipe_radius_m, -R.T @ t)
            else:
                f = fit_axis([pl for _, _, pl in sel], cfg.pipe_radius_m, prior)
            return f if f is None or _plausible(f) else None

        tol_r = cfg.weak_radius_tolerance * cfg.pipe_radius_m

        def misfit(sel: list[tuple[int, Limb, Plane]], fit: AxisFit) -> float:
            """How far (px) the set's planes are from the cylinder they fit; inf when its radius,
            fitted freely where the two cameras fix it, is not the pipe's. 0 for strong edges
            alone and for one camera alone (nothing to check weak edges against)."""
            if all(not lb.weak for _, lb, _ in sel) or len({j for j, _, _ in sel}) == 1:
                return 0.0
            worst = max(self._plane_px(fit, pl, cams) for _, _, pl in sel)
            if (
                worst <= cfg.weak_edge_tolerance_px
                and self._radius_sigma(fit, [pl for _, _, pl in sel], cams) < 0.5 * tol_r
            ):
                free = fit_of(sel, 0.0)
                if free is None or abs(free.r - cfg.pipe_radius_m) > tol_r:
                    return float("inf")
            return worst

        # the largest set of edges that agree on a cylinder of the pipe's radius (strong edges first)
        fit, chosen = None, []
        for size in range(len(cands), 1, -1):
            best: tuple[float, float] | None = None
            for sel in map(list, itertools.combinations(cands, size)):
                f = fit_of(sel, cfg.radius_prior_weight)
                if f is None:
                    continue
                bad = misfit(sel, f)
                if bad > cfg.weak_edge_tolerance_px:
                    continue
                rank = (float(sum(lb.weak for _, lb, _ in sel)), bad)
                if best is None or rank < best:
                    best, fit, chosen = rank, f, sel
            if fit is not None:
                break
        kept: list[list[Limb]] = [[lb for j, lb, _ in chosen if j == k] for k in (0, 1)]
        if fit is None:
            n = [sum(1 for j, _, _ in cands if j == k) for k in (0, 1)]
            return (
                None,
                kept,
                f"no pipe in view: the straight edges ({n[0]} left, {n[1]} right) do not fix a cylinder axis",
            )
        return fit, kept, ""

    def _radius_sigma(self, fit: AxisFit, planes: list[Plane], cams: list) -> float:
        """Standard deviation (m) of the radius the planes fit without the radius prior,
        for an error of one pixel per plane at the pipe's range: small when the two
        cameras' planes fix the pipe's depth, large when the pipe lies along the
        baseline (their planes nearly coincide) or far away."""
        rows = []
        for pl in planes:
            cam, R, t = cams[pl.camera]
            rng = max(float(np.linalg.norm(fit.p + R.T @ t)), 0.1)
            rows.append(np.append(pl.n, -1.0) * float(cam.K[0, 0]) / rng)  # one pixel of error per row
        rows.append(np.append(fit.a, 0.0) * 1e6)  # the axis point across the axis: held
        A = np.array(rows)
        try:
            cov = np.linalg.inv(A.T @ A)
        except np.linalg.LinAlgError:
            return float("inf")
        return float(np.sqrt(max(cov[3, 3], 0.0)))

    def _plane_px(self, fit: AxisFit, plane: Plane, cams: list) -> float:
        """How far (px) a tangent plane is from the fitted cylinder: its distance error
        at the pipe's range over the camera's focal length, and its tilt from the axis."""
        cam, R, t = cams[plane.camera]
        centre = -R.T @ t
        rng = max(float(np.linalg.norm(fit.p - centre)), 0.1)
        dist_err = abs(float(plane.n @ fit.p - plane.d) - fit.r)
        tilt = abs(float(plane.n @ fit.a)) * 0.25 * self.config.pipe_length_m  # across over a quarter of the pipe
        return float(cam.K[0, 0]) * (dist_err + tilt) / rng

    def _fit(
        self,
        sils: list[Silhouette | None],
        cams: list[tuple[CameraModel, np.ndarray, np.ndarray]],
        gravity_cam: np.ndarray | None,
        vehicle_T_camera: np.ndarray | None,
        blocked: list[np.ndarray | None] | None = None,
        images: list[RestoredImage] | None = None,
    ) -> PipeDetection:
        cfg = self.config
        blocked = blocked if blocked is not None else [None] * len(sils)
        fit, kept, why = self._planes(sils, cams)
        if fit is None:
            return PipeDetection(0.0, why)
        unseen: int | None = None  # the camera that shows no pipe where the cylinder projects
        look = self._second_look(fit, kept, sils, cams, images, blocked) if images is not None else None
        if look is not None:
            k, sil_k = look
            trial = list(sils)
            trial[k] = sil_k
            fit2, kept2, _ = self._planes(trial, cams)
            if fit2 is not None and min(len(kept2[0]), len(kept2[1])) >= 1:
                fit, kept, sils = fit2, kept2, trial
            else:
                unseen = k
        if not _plausible(fit):
            return PipeDetection(
                0.0, f"implausible cylinder fit (radius {fit.r:.3f} m, {float(np.linalg.norm(fit.p)):.2f} m away)"
            )
        for sil, limbs in zip(sils, kept):
            if sil is not None:
                sil.limbs = limbs
        ends, end_rms, outlines = self._ends(fit, sils, cams, self._centroid_s(fit, sils, cams))
        rim_ends: list[RimEnd] = []
        rim_refused: list[RefusedEnd] = []
        per_cam_edges = [len(k) for k in kept]
        # the rim search needs an axis the cameras checked against each other: edges of both
        # cameras, one of them with two (one edge each fixes an axis with nothing to check it)
        checked = len(cams) > 1 and min(per_cam_edges) >= 1 and sum(per_cam_edges) >= 3
        if not ends and cfg.rim_search.enabled and checked:
            # an axis that one camera's two edges fix and one edge of the other turns (2+1,
            # 1+2): a wrong axis still has an end somewhere along it where one camera's rim
            # image crosses the pipe's outline; only an end both cameras see there is one
            one_pair = sorted(per_cam_edges) == [1, 2]
            rim_ends, rim_refused = self._rim_ends(fit, sils, cams, blocked, confirm=one_pair)
            if rim_ends:
                ends, end_rms, outlines = self._ends(fit, sils, cams, self._centroid_s(fit, sils, cams))
        # a refused end is still where the cameras' mean fall along the rim stands out: on a
        # right axis that is the pipe's end (one camera saw it too faintly, or not at all), one
        # pipe length from the other end; on an axis wrong in depth at that end, where one
        # camera's image of the end meets the axis, at another distance. With the other end
        # taken, the two ends' distance is checked with it as with two ends taken.
        length_with_refused = float("nan")
        if len(ends) == 1 and rim_refused:
            length_with_refused = min(abs(r.end.s - ends[0]) for r in rim_refused)
        outlines_by_end = {k: [j for j in outlines if k in outlines[j]] for k in range(len(ends))}
        refine_rms = float("nan")
        length_measured = abs(ends[1] - ends[0]) if len(ends) == 2 else float("nan")
        if cfg.refine:
            obs = [
                _observations(sil, cam, R, t, outlines.get(j, {}))
                for j, (sil, (cam, R, t)) in enumerate(zip(sils, cams))
                if sil is not None and sil.limbs
            ]
            if len(ends) == 2:
                length_measured = abs(ends[1] - ends[0])
            new_fit, new_ends, rms = refine(fit, ends, obs, cfg.pipe_radius_m, length_prior=cfg.pipe_length_m)
            refine_rms = rms
            if np.isfinite(rms) and rms < 4.5 and abs(new_fit.r - cfg.pipe_radius_m) < 0.6 * cfg.pipe_radius_m:
                fit, ends = new_fit, new_ends
        centroid_s = self._centroid_s(fit, sils, cams)
        disagree = self._one_camera_disagreement(fit, kept, sils, cams)
        quality: dict = {
            "plane_rms_m": fit.plane_rms,
            "radius_m": fit.r,
            "views": fit.n_cameras,
            "views_used": f"{len(kept[0])}+{len(kept[1])}",
            "weak_edges": sum(lb.weak for k in kept for lb in k),
            "limb_rms_px": [lb.rms_px for s in sils if s is not None for lb in s.limbs],
            "end_rms_px": end_rms,
            "refine_rms_px": refine_rms,
            "length_before_prior_m": length_measured,
            "rim_search_ends": len(rim_ends),
            "rim_ends_unconfirmed": len(rim_refused),
            "length_with_refused_end_m": length_with_refused,
            "rim_end_cameras": [
                {
                    ("left", "right")[j]: {"fall": c.fall, "z": c.z, "peak_offset_m": c.peak_offset_m}
                    for j, c in e.per_camera.items()
                }
                for e in rim_ends + [r.end for r in rim_refused]
            ],
            "one_camera_disagreement_deg": disagree,
        }
        reasons: list[str] = []
        for r in rim_refused:
            names = " and ".join(("left", "right")[j] for j in r.unconfirmed)
            reasons.append(f"an end found along the rim is not confirmed by the {names} camera on its own: not taken")
        off = cfg.grasp_offset
        n_end_views = 0
        if len(ends) >= 2:
            s_a, s_b = sorted(ends, key=lambda s: float(np.linalg.norm(fit.p + s * fit.a)))[:2]
            inward = np.sign(s_b - s_a) or 1.0
            grasp_s = 0.5 * (s_a + s_b) + inward * (off - 0.5 * cfg.pipe_length_m)
            quality["length_m"] = abs(s_b - s_a)
            dl = abs(length_measured - cfg.pipe_length_m)
            f_end = float(np.exp(-((dl / cfg.length_tolerance_m) ** 2)))  # two ends the wrong distance apart
            if dl > cfg.length_tolerance_m:
                reasons.append(f"the two ends are {length_measured:.2f} m apart, the pipe is {cfg.pipe_length_m:.2f} m")
            end_s = s_a
        elif len(ends) == 1:
            end_s = ends[0]
            inward = np.sign(centroid_s - end_s) or 1.0
            grasp_s = end_s + inward * off
            f_end = 1.0
            if np.isfinite(length_with_refused):  # the refused end's distance counts as two ends' would
                dl = abs(length_with_refused - cfg.pipe_length_m)
                f_end = float(np.exp(-((dl / cfg.length_tolerance_m) ** 2)))
                if dl > cfg.length_tolerance_m:
                    reasons.append(
                        f"the end refused along the rim is {length_with_refused:.2f} m from the one taken,"
                        f" the pipe is {cfg.pipe_length_m:.2f} m"
                    )
        else:
            end_s = None
            grasp_s = centroid_s
            f_end = NO_END_FACTOR
            reasons.append("no pipe end visible: the position along the axis is a guess")
        if ends:
            n_end_views = max(len(outlines_by_end.get(k, ())) for k in range(len(ends)))
            end_fit = float(np.nanmax(end_rms)) if len(end_rms) else 0.0
            f_end *= _soft(end_fit, 4.0)
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
        focal = float(cams[0][0].K[0, 0])
        plane_px = fit.plane_rms * focal / max(rng, 0.1)
        fit_px = refine_rms if np.isfinite(refine_rms) else plane_px
        f_fit = _soft(fit_px, 4.0)
        f_radius = max(0.0, 1.0 - abs(fit.r - cfg.pipe_radius_m) / (0.6 * cfg.pipe_radius_m))
        limb_rms = max(quality["limb_rms_px"]) if quality["limb_rms_px"] else 0.0
        f_straight = _soft(limb_rms, 4.0)
        per_cam = [len(k) for k in kept]
        f_views = 1.0 if len(cams) == 1 else {4: 1.0, 3: 0.9}.get(sum(per_cam), 0.75)
        if sum(per_cam) == 3:
            one = "right" if per_cam[1] == 1 else "left"
            reasons.append(f"the {one} camera saw one edge: the axis from the known radius")
            if disagree > MAX_ONE_CAMERA_DISAGREEMENT_DEG:
                f_views *= DISAGREEMENT_FACTOR
                two = "left" if one == "right" else "right"
                reasons.append(f"the axis is {disagree:.0f} deg from the one the {two} camera's two edges fix")
        elif per_cam == [1, 1]:  # two planes for four unknowns and the radius: nothing checks them
            f_views = ONE_EDGE_EACH_FACTOR
            reasons.append("each camera saw one edge: the axis from the known radius, unchecked")
        contradicted = [r for r in rim_refused if r.contradicting]
        if contradicted:
            f_views *= REFUSED_END_FACTOR ** len(contradicted)
            for r in contradicted:
                names = " and ".join(("left", "right")[j] for j in r.contradicting)
                reasons.append(
                    f"the {names} camera places the refused end elsewhere along the axis: the axis is off there"
                )
        quality["rim_ends_contradicted"] = len(contradicted)
        if unseen is not None:
            f_views *= UNSEEN_FACTOR
            reasons.append(
                f"the {'right' if unseen == 1 else 'left'} camera shows no edges where the cylinder projects"
            )
        elif len(cams) > 1 and min(per_cam) == 0 and not ends:
            # one camera's axis that the other camera cannot look at (the cylinder projects
            # mostly outside its view) and no end to place it along itself: nothing checks it
            f_views *= UNCHECKED_FACTOR
            other = "left" if per_cam[0] == 0 else "right"
            reasons.append(f"the {other} camera cannot see where the cylinder projects and no end checks the axis")
        weak_used = sum(lb.weak for k in kept for lb in k)
        faint_used = sum(lb.faint for k in kept for lb in k)
        f_views *= 0.95**weak_used * FAINT_EDGE_FACTOR**faint_used
        if faint_used:
            reasons.append(f"{faint_used} edge(s) from the colour against the background (a faint pipe)")
        quality["faint_edges"] = faint_used
        baseline = -cams[1][1].T @ cams[1][2] if len(cams) > 1 else None
        limbs = [lb for k in kept for lb in k]
        edge_px = float(
            np.sqrt(
                EDGE_BIAS_PX**2 + np.mean([lb.rms_px**2 / max(len(lb.points) / CORRELATION_PX, 1.0) for lb in limbs])
            )
        )
        end_fit_px = float(np.nanmax(end_rms)) if len(end_rms) else 1.0
        end_px = float(np.sqrt(END_BIAS_PX**2 + end_fit_px**2 / 4.0))
        quality["edge_sigma_px"], quality["end_sigma_px"] = edge_px, end_px
        sigma_depth = self._depth_sigma(fit, rng, focal, baseline, per_cam, n_end_views, edge_px, end_px)
        # the chance that a normal error of that size stays within the grasp's position tolerance
        f_geom = float(math.erf(POSITION_TOLERANCE_M / (sigma_depth * math.sqrt(2.0)))) if sigma_depth > 0 else 1.0
        if fit.n_cameras < 2:
            what = "one camera" if len(cams) == 1 else "seen by one camera only"
            reasons.append(f"{what}: depth from the known radius")
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

    @staticmethod
    def _depth_sigma(
        fit: AxisFit,
        rng: float,
        focal: float,
        baseline: np.ndarray | None,
        per_cam: list[int],
        end_views: int,
        edge_px: float,
        end_px: float,
    ) -> float:
        """Expected depth error (m) of the pipe from its geometry: the two cameras'
        tangent planes (the baseline's part across the axis), the apparent width
        with the known radius, the ends' disparity when both cameras saw an end;
        with an error per edge of ``sqrt(EDGE_BIAS_PX^2 + (rms / sqrt(n_independent))^2)`` from
        the edges' fits (``END_BIAS_PX`` and the end fits' rms for ends).
        ``baseline``: the second camera's centre in the first's frame (None: one camera)."""
        inv = 0.0
        k = rng * rng / focal
        if baseline is not None and min(per_cam) >= 1:
            across = float(np.linalg.norm(np.cross(fit.a, baseline)))
            if across > 1e-6:
                inv += (across / (k * edge_px)) ** 2
        if max(per_cam) >= 2:
            inv += (2.0 * fit.r / (np.sqrt(2.0) * k * edge_px)) ** 2
        if baseline is not None and end_views >= 2:
            inv += (float(np.linalg.norm(baseline)) / (k * end_px)) ** 2
        return float(1.0 / np.sqrt(inv)) if inv > 0 else float("inf")

    def _one_camera_disagreement(
        self, fit: AxisFit, kept: list[list[Limb]], sils: list[Silhouette | None], cams: list
    ) -> float:
        """For an axis from the two edges of one camera and one of the other (``2+1``,
        ``1+2``): the angle (deg) between it and the axis the two edges of that one camera
        fix alone with the known radius (:func:`vision.cylinder.axis_from_one_camera`); NaN
        for other sets of edges."""
        per = [len(k) for k in kept]
        if len(cams) != 2 or sorted(per) != [1, 2]:
            return float("nan")
        j = 0 if per[0] == 2 else 1
        sil = sils[j]
        if sil is None:
            return float("nan")
        cam, R, t = cams[j]
        ray = np.append(undistort_points(sil.centroid, cam)[0], 1.0)
        planes = [plane_from_line(lb.line_norm, R, t, ray, j) for lb in kept[j]]
        mono = axis_from_one_camera(planes[0], planes[1], self.config.pipe_radius_m, -R.T @ t)
        if mono is None:
            return float("nan")
        return float(np.degrees(np.arccos(min(1.0, abs(float(mono.a @ fit.a))))))

    def _centroid_s(self, fit: AxisFit, sils: list, cams: list) -> float:
        vals = []
        for sil, (cam, R, t) in zip(sils, cams):
            if sil is None:
                continue
            xy = undistort_points(sil.centroid, cam)[0]
            origin = -R.T @ t
            vals.append(closest_point_on_axis(fit, origin, R.T @ np.append(xy, 1.0)))
        return float(np.mean(vals)) if vals else 0.0

    def _second_look(
        self,
        fit: AxisFit,
        kept: list[list[Limb]],
        sils: list[Silhouette | None],
        cams: list,
        images: list[RestoredImage],
        blocked: list[np.ndarray | None],
    ) -> tuple[int, Silhouette] | None:
        """For an axis from the two edges of one camera of a pair: the other camera's edges,
        searched around where that cylinder projects (a region drawn along the projected
        axis at the pipe's apparent width, :func:`vision.silhouette.analyse`). The edges it
        finds are weak: the axis takes them only where the geometry agrees. Returns the
        other camera's index and its silhouette; None when there is nothing to look at (not
        that case, or the cylinder projects mostly outside the other camera's view)."""
        if len(cams) != 2 or len(images) != 2:
            return None
        per = [len(k) for k in kept]
        if sorted(per) != [0, 2]:
            return None
        j = 0 if per[0] == 2 else 1
        k = 1 - j
        sil_j = sils[j]
        assert sil_j is not None
        cam_j, R_j, t_j = cams[j]
        tips = np.array([sil_j.centroid + e * sil_j.direction for e in sil_j.extent])
        s_tip = [
            closest_point_on_axis(fit, -R_j.T @ t_j, R_j.T @ np.append(x, 1.0)) for x in undistort_points(tips, cam_j)
        ]
        cam_k, R_k, t_k = cams[k]
        X = (fit.p[None, :] + np.linspace(min(s_tip), max(s_tip), 24)[:, None] * fit.a[None, :]) @ R_k.T + t_k
        if np.any(X[:, 2] <= 0.1):
            return None
        px = project_points(X, cam_k)
        W, H = cam_k.size
        inside = (px[:, 0] >= 0) & (px[:, 0] < W) & (px[:, 1] >= 0) & (px[:, 1] < H)
        if inside.mean() < 0.5:
            return None
        width = float(np.median(2.0 * cam_k.K[0, 0] * fit.r / X[:, 2]))
        mask = np.zeros((H, W), np.uint8)
        cv2.polylines(mask, [np.round(px).astype(np.int32)], False, 255, max(3, int(round(width))))
        arm = blocked[k]
        if arm is not None:
            mask[arm > 0] = 0
        x, y, w, h = cv2.boundingRect(mask)
        if w == 0 or cv2.countNonZero(mask) < 100:
            return None
        region = Region(np.ascontiguousarray(mask[y : y + h, x : x + w]), x, y, (H, W))
        sil_k = analyse(
            region, cam_k, blocked[k], images[k], max_limb_rms_px=self.config.max_limb_rms_px, search=self.config.edges
        )
        if sil_k.score is None:  # no pipe-like colour against the surroundings there: nothing to find
            sil_k.limbs = []
        faint = any(lb.faint for lb in kept[j])
        for lb in sil_k.limbs:
            lb.weak, lb.faint = True, faint
        return k, sil_k

    def _rim_ends(
        self,
        fit: AxisFit,
        sils: list[Silhouette | None],
        cams: list,
        blocked: list[np.ndarray | None],
        confirm: bool = False,
    ) -> tuple[list[RimEnd], list[RefusedEnd]]:
        """Pipe ends searched along the fitted axis (:func:`vision.end_search.search_end`)
        beyond each end of the colour regions, in every camera with a pipe score whose
        region does not run into the border or the arm on that side; the outline points
        found join the silhouettes' ends (for :meth:`_ends`). With ``confirm`` (an axis
        that both cameras' pairs of edges do not fix), an end is taken only when every
        camera of the pair confirms it on its own (:meth:`vision.end_search.RimEnd.unconfirmed`).
        Returns the ends taken and those refused (:class:`RefusedEnd`: the cameras that did
        not confirm them, and those of them that place the end elsewhere while in view of it)."""
        cfg = self.config
        extremes: dict[float, list[tuple[float, RimView]]] = {1.0: [], -1.0: []}
        edges_stop: dict[float, list[float]] = {1.0: [], -1.0: []}
        for j, (sil, (cam, R, t)) in enumerate(zip(sils, cams)):
            if sil is None or sil.score is None or len(sil.limbs) < 1:
                continue
            origin = -R.T @ t
            tips = np.array(
                [sil.centroid + sil.extent[0] * sil.direction, sil.centroid + sil.extent[1] * sil.direction]
            )
            s_tip = [closest_point_on_axis(fit, origin, R.T @ np.append(x, 1.0)) for x in undistort_points(tips, cam)]
            view = RimView(j, cam, R, t, sil.score, blocked[j])
            # where the straight edges stop along the axis (their first and last points, in
            # undistorted pixels, follow the region's axis)
            s_limbs = [
                closest_point_on_axis(fit, origin, R.T @ np.linalg.solve(cam.K, np.append(q, 1.0)))
                for lb in sil.limbs
                for q in lb.points[[0, -1]]
            ]
            for sign, s_end, s_other in ((-1, s_tip[0], s_tip[1]), (1, s_tip[1], s_tip[0])):
                if sign in sil.hidden_ends or abs(s_end - s_other) < 4.0 * fit.r:
                    continue
                outward = float(np.sign(s_end - s_other))
                extremes[outward].append((s_end, view))
                if s_limbs:
                    edges_stop[outward].append(max(outward * x for x in s_limbs) * outward)
        found: dict[int, dict[int, np.ndarray]] = {}
        rim_ends: list[RimEnd] = []
        refused: list[RefusedEnd] = []
        for outward, entries in extremes.items():
            if not entries:
                continue
            s_from = max(outward * s for s, _ in entries) * outward  # the outermost extreme of the regions
            end = search_end(fit, [v for _, v in entries], s_from, outward, cfg.rim_search)
            if end is None and edges_stop[outward]:
                # a colour region that ran on past the end (over a floor of the pipe's colour, in
                # turbid water) starts the search beyond it: again from where the edges stop
                s_edges = max(outward * s for s in edges_stop[outward]) * outward
                if outward * (s_from - s_edges) > cfg.rim_search.inside_m:
                    end = search_end(fit, [v for _, v in entries], s_edges, outward, cfg.rim_search)
            if end is None:
                continue
            bad = end.unconfirmed(cfg.rim_search, tuple(range(len(cams)))) if confirm else []
            if bad:
                # a camera not searched on this side (its region runs into the border or the arm
                # there) or whose rim image at the end is cut cannot see the end: no evidence
                searched = {v.index for _, v in entries}
                blind = set(end.hidden) | (set(range(len(cams))) - searched)
                refused.append(RefusedEnd(end, bad, end.contradicted_by(cfg.rim_search, tuple(bad), blind)))
            else:
                rim_ends.append(end)
                for j, pts in end.outlines.items():
                    found.setdefault(j, {})[int(outward)] = pts
        if found:  # the outlines found before gave no end: the rim's replace them
            for j, sil in enumerate(sils):
                if sil is not None:
                    sil.ends = found.get(j, {})
        return rim_ends, refused

    def _ends(self, fit: AxisFit, sils: list, cams: list, middle_s: float) -> tuple[list[float], list[float], dict]:
        """Axis coordinates (m) of the visible pipe ends, the rms (px) of their fits,
        and the outline points kept for each (camera index -> {end index: (k, 2)}):
        points farther than ``max(1.5 px, 3 x median)`` from the fitted rim are
        dropped (e.g. a shading edge inside the pipe). ``middle_s``: where the pipe's
        body is along the axis (the colour regions' centroid), which tells each end's
        outside: the outline is fitted to the rim's arc on that side only."""
        found: list[tuple[float, list]] = []  # (s0, [(camera, R, t, pts, f)])
        for j, (sil, (cam, R, t)) in enumerate(zip(sils, cams)):
            if sil is None:
                continue
            origin = -R.T @ t
            for pts in sil.ends.values():
                c = pts.mean(axis=0)
                s0 = closest_point_on_axis(fit, origin, R.T @ np.append(c, 1.0))
                entry = (j, R, t, pts, float(cam.K[0, 0]))
                for near in found:
                    if abs(near[0] - s0) < 0.25 * self.config.pipe_length_m:
                        near[1].append(entry)
                        break
                else:
                    found.append((s0, [entry]))
        ends: list[float] = []
        rms: list[float] = []
        kept: dict[int, dict[int, np.ndarray]] = {}
        for s0, group in found:
            cams_ = [e[1:] for e in group]
            outward = float(np.sign(s0 - middle_s)) if abs(s0 - middle_s) > 2.0 * fit.r else None
            s, rms0 = fit_end(fit, s0, 3.0 * fit.r + 0.02, cams_, outward=outward)
            face_like_pipe = True
            if outward is not None and any(cap_faces_camera(fit, s, outward, R, t) for R, t, _, _ in cams_):
                # the cap's face in view: the outline is its far rim if the face looks like the
                # pipe, its near rim if not (a dark or open end); the one the outline fits better
                s2, rms2 = fit_end(fit, s0, 3.0 * fit.r + 0.02, cams_, outward=outward, face_like_pipe=False)
                if rms2 < rms0:
                    s, face_like_pipe = s2, False
            clean = []
            for j, R, t, pts, f in group:
                d = rim_point_distances(fit, s, R, t, pts, outward, face_like_pipe) * f
                keep = d <= max(1.5, 3.0 * float(np.median(d)))
                if keep.sum() >= 6:
                    clean.append((j, R, t, pts[keep], f))
            if not clean:
                continue
            s, r = fit_end(fit, s, 0.02, [e[1:] for e in clean], outward=outward, face_like_pipe=face_like_pipe)
            if np.isfinite(r) and r < self.config.max_end_rms_px:
                k = len(ends)
                ends.append(s)
                rms.append(r)
                for j, _, _, pts, _ in clean:
                    kept.setdefault(j, {})[k] = pts
        return ends, rms, kept


def _observations(sil: Silhouette, cam: CameraModel, R: np.ndarray, t: np.ndarray, ends: dict) -> Observations:
    """Edge points of one view in normalized coordinates, for :func:`vision.refine.refine`."""
    Kinv = np.linalg.inv(cam.K)
    norm = lambda P: (np.column_stack([P, np.ones(len(P))]) @ Kinv.T)[:, :2]  # noqa: E731 - undistorted px -> normalized
    return Observations(R, t, float(cam.K[0, 0]), [norm(lb.points) for lb in sil.limbs[:2]], ends)


def _soft(value: float, scale: float) -> float:
    """A factor near 1 for ``value`` well under ``scale``, 0.5 at it, falling fast beyond."""
    return 1.0 / (1.0 + (max(value, 0.0) / scale) ** 4) if np.isfinite(value) else 0.5


def _plausible(fit: AxisFit) -> bool:
    """A cylinder the cameras can see: a positive radius, its axis point (closest to the
    left camera) finite, within 10 m and more than 5 cm in front of the left camera."""
    return bool(fit.r > 0 and np.all(np.isfinite(fit.p)) and fit.p @ fit.p <= 100.0 and _depth(fit) > 0.05)


def _depth(fit: AxisFit) -> float:
    return float(fit.p[2])
