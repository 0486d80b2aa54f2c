"""One image: the colour region of the pipe and its straight edges (pixels).

Steps, all on one (raw, distorted) image:

1. HSV threshold (OpenCV scales: hue 0-179, saturation and value 0-255; MARIS
   used hue 22-35, saturation >= 63, value >= 30). A hue range with
   ``lo > hi`` wraps around (for red targets).
2. The arm's reprojection mask (if any) is removed, small speckle opened away.
3. The largest connected region is the pipe; other regions lying along its
   principal axis (the pipe cut in two by the arm) join it.
4. Its outer contour is split into the two long edges (limbs: points beside
   the principal axis, away from the ends) and the two end outlines; points on
   the image border or next to the arm mask are not edges of the pipe and are
   dropped.
5. Each limb is fitted as a straight line (Huber-weighted) in undistorted
   pixel coordinates, then moved outward by half a pixel: the contour runs
   through the centres of the outermost pipe pixels, the true edge lies half a
   pixel further out.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from vision.calibration import CameraModel, undistort_points


@dataclass(frozen=True)
class HsvRange:
    """Colour thresholds on OpenCV's HSV scales (hue 0-179, sat/value 0-255)."""

    hue: tuple[int, int] = (22, 35)
    sat_min: int = 63
    val_min: int = 30
    sat_max: int = 255
    val_max: int = 255

    def check(self) -> list[str]:
        """Problems with the thresholds (empty when they are usable)."""
        errs = []
        if not all(0 <= h <= 179 for h in self.hue):
            errs.append(f"hue bounds must be within 0-179 (OpenCV scale), got {list(self.hue)}")
        for name, lo, hi in (("saturation", self.sat_min, self.sat_max), ("value", self.val_min, self.val_max)):
            if not (0 <= lo <= hi <= 255):
                errs.append(f"{name} bounds must satisfy 0 <= min <= max <= 255, got {lo}..{hi}")
        return errs


def hsv_mask(bgr: np.ndarray, rng: HsvRange, coarse_above: int = 800) -> np.ndarray:
    """uint8 mask (255 inside the colour range) of a BGR image. Images wider than
    ``coarse_above`` px are first thresholded at half resolution (every other
    pixel), and at full resolution only around what that found (+16 px)."""
    import cv2

    h, w = bgr.shape[:2]
    if w > coarse_above:
        small = _hsv_mask(np.ascontiguousarray(bgr[::2, ::2]), rng)
        x, y, bw, bh = cv2.boundingRect(small)
        out = np.zeros((h, w), np.uint8)
        if bw == 0:
            return out
        x0, y0 = max(2 * x - 16, 0), max(2 * y - 16, 0)
        x1, y1 = min(2 * (x + bw) + 16, w), min(2 * (y + bh) + 16, h)
        out[y0:y1, x0:x1] = _hsv_mask(bgr[y0:y1, x0:x1], rng)
        return out
    return _hsv_mask(bgr, rng)


def _hsv_mask(bgr: np.ndarray, rng: HsvRange) -> np.ndarray:
    import cv2

    hsv = cv2.cvtColor(bgr, cv2.COLOR_BGR2HSV)
    h0, h1 = rng.hue
    if h0 <= h1:
        return cv2.inRange(hsv, (h0, rng.sat_min, rng.val_min), (h1, rng.sat_max, rng.val_max))
    a = cv2.inRange(hsv, (h0, rng.sat_min, rng.val_min), (179, rng.sat_max, rng.val_max))
    b = cv2.inRange(hsv, (0, rng.sat_min, rng.val_min), (h1, rng.sat_max, rng.val_max))
    return cv2.bitwise_or(a, b)


@dataclass
class Limb:
    """A straight silhouette edge: line ``(a, b, c)`` in undistorted pixels
    (unit normal pointing to the pipe's inside), in normalized coordinates,
    rms residual (px), the fitted points (k, 2 undistorted px), end points for drawing."""

    line_px: np.ndarray
    line_norm: np.ndarray
    rms_px: float
    points: np.ndarray
    segment: np.ndarray


@dataclass
class Silhouette:
    """The pipe's region in one image and its parts (pixels of the raw image)."""

    area: int
    bbox: tuple[int, int, int, int]
    centroid: np.ndarray
    direction: np.ndarray
    half_width: float
    extent: tuple[float, float]
    contour: np.ndarray
    limbs: list[Limb] = field(default_factory=list)
    #: End outline points (undistorted normalized coordinates) per end: -1 (low s), +1 (high s)
    ends: dict[int, np.ndarray] = field(default_factory=dict)
    #: Ends whose outline touches the image border or the arm: not usable
    hidden_ends: tuple[int, ...] = ()
    reason: str = ""

    def to_dict(self) -> dict:
        return {
            "area_px": self.area,
            "bbox": list(self.bbox),
            "centroid": self.centroid.tolist(),
            "direction": self.direction.tolist(),
            "half_width_px": self.half_width,
            "limbs": [
                {"segment": lb.segment.tolist(), "rms_px": lb.rms_px, "points": len(lb.points)} for lb in self.limbs
            ],
            "visible_ends": sorted(self.ends),
            "reason": self.reason,
        }


def _moments_axis(mask: np.ndarray) -> tuple[np.ndarray, np.ndarray, float, float, int]:
    """Centroid (u, v), unit principal direction, std along and across it, and
    pixel count of a binary mask (image moments, no pixel lists)."""
    import cv2

    m = cv2.moments(mask, binaryImage=True)
    n = m["m00"]
    if n <= 0:
        return np.zeros(2), np.array([1.0, 0.0]), 0.0, 0.0, 0
    c = np.array([m["m10"] / n, m["m01"] / n])
    cov = np.array([[m["mu20"], m["mu11"]], [m["mu11"], m["mu02"]]]) / n
    evals, evecs = np.linalg.eigh(cov)
    return c, evecs[:, 1], float(np.sqrt(max(evals[1], 0.0))), float(np.sqrt(max(evals[0], 0.0))), int(n)


@dataclass(frozen=True)
class Region:
    """The pipe's colour region: a uint8 mask (255 inside) of the image's
    sub-rectangle at column ``x0``, row ``y0``; ``shape``: the full image's (h, w)."""

    mask: np.ndarray
    x0: int
    y0: int
    shape: tuple[int, int]

    def full(self) -> np.ndarray:
        """The region as a full-size mask."""
        out = np.zeros(self.shape, np.uint8)
        h, w = self.mask.shape
        out[self.y0 : self.y0 + h, self.x0 : self.x0 + w] = self.mask
        return out


def select_region(mask: np.ndarray, min_area: int) -> tuple[Region | None, str]:
    """The pipe's region among the connected components of ``mask`` (None and why if none)."""
    import cv2

    x0, y0, bw, bh = cv2.boundingRect(mask)
    if bw == 0 or bh == 0:
        return None, "no pixel in the colour range"
    crop = mask[y0 : y0 + bh, x0 : x0 + bw]
    n, labels, stats, cents = cv2.connectedComponentsWithStats(crop, connectivity=8)
    if n <= 1:
        return None, "no pixel in the colour range"
    areas = stats[1:, cv2.CC_STAT_AREA]
    order = np.argsort(areas)[::-1] + 1
    best = int(order[0])
    if stats[best, cv2.CC_STAT_AREA] < min_area:
        return None, f"colour region too small ({int(stats[best, cv2.CC_STAT_AREA])} px < {min_area} px)"
    keep = [best]
    comp = (labels == best).astype(np.uint8)
    c, u, sd_along, sd_across, _ = _moments_axis(comp)
    if sd_along > 2.0 * sd_across:  # elongated: pieces on its axis line belong to it (arm crossing)
        nrm = np.array([-u[1], u[0]])
        band = max(3.0 * sd_across, 3.0)
        for lab in order[1:]:
            if stats[lab, cv2.CC_STAT_AREA] < max(min_area // 4, 4):
                break
            if abs((cents[lab] - c) @ nrm) < band:
                keep.append(int(lab))
    if len(keep) > 1:
        comp = np.isin(labels, keep).astype(np.uint8)
    return Region(comp * 255, int(x0), int(y0), mask.shape[:2]), ""


def _fit_line(pts_px: np.ndarray) -> tuple[np.ndarray, float]:
    """Huber line fit ``(a, b, c)`` (unit normal) and rms residual (px) of inliers."""
    import cv2

    use = pts_px
    for _ in range(2):  # Huber fit, then again without the points beyond 2.5 sigma
        vx, vy, x0, y0 = cv2.fitLine(use.astype(np.float32), cv2.DIST_HUBER, 0, 0.01, 0.01).reshape(-1)
        n = np.array([-vy, vx], dtype=float)
        line = np.array([n[0], n[1], -(n[0] * x0 + n[1] * y0)])
        res = pts_px @ line[:2] + line[2]
        sigma = 1.4826 * float(np.median(np.abs(res))) + 0.05
        inl = np.abs(res) < max(2.5 * sigma, 0.3)
        if inl.sum() < 6:
            break
        use = pts_px[inl]
    rms = float(np.sqrt(np.mean(res[inl] ** 2))) if inl.any() else float("inf")
    return line, rms


def colour_score(bgr: np.ndarray, box: tuple[int, int, int, int]) -> tuple[np.ndarray, int, int]:
    """Yellowness ``max(R, G) - B`` (float32, 8-bit units) over ``box`` (x, y, w, h)
    grown by 10 px: high on the pipe, low on the blue-grey pool. Returns the crop
    and its top-left corner."""
    H, W = bgr.shape[:2]
    x0, y0, bw, bh = box
    x0, y0, x1, y1 = max(x0 - 10, 0), max(y0 - 10, 0), min(x0 + bw + 10, W), min(y0 + bh + 10, H)
    import cv2

    crop = bgr[y0:y1, x0:x1].astype(np.float32)
    score = np.maximum(crop[:, :, 1], crop[:, :, 2]) - crop[:, :, 0]
    return cv2.GaussianBlur(score, (5, 5), 0.8), x0, y0  # sensor noise down, edges kept symmetric


_STEPS = np.arange(-4.0, 4.01, 0.25, dtype=np.float32)  # px along the inward normal (+ inside)
_SMOOTH = np.ones(4, np.float32) / 4.0  # 1 px box over the 0.25 px samples


def refine_edges(
    score: np.ndarray,
    ox: int,
    oy: int,
    pts: np.ndarray,
    normals: np.ndarray,
    min_contrast: float = 6.0,
    reach: float = 3.0,
) -> tuple[np.ndarray, np.ndarray]:
    """Sub-pixel edge positions near contour points ``pts`` (k, 2, raw px) along
    inward unit ``normals`` (k, 2): the steepest descent of the score profile
    (inside to outside) within ``reach`` px of the point, refined by a parabola.
    Returns the refined points and the mask of points with enough contrast."""
    import cv2

    if len(pts) == 0:
        return pts, np.zeros(0, bool)
    steps = _STEPS[::-1]  # from inside (+4) to outside (-4)
    sx = (pts[:, 0:1] - ox) + steps[None, :] * normals[:, 0:1]
    sy = (pts[:, 1:2] - oy) + steps[None, :] * normals[:, 1:2]
    prof = cv2.remap(
        score, sx.astype(np.float32), sy.astype(np.float32), cv2.INTER_LINEAR, borderMode=cv2.BORDER_REPLICATE
    )
    drop = prof[:, :-4] - prof[:, 4:]  # fall over 1 px, centred between samples i and i+4
    centre = 0.5 * (steps[:-4] + steps[4:])
    drop = np.where(np.abs(centre)[None, :] <= reach, drop, -np.inf)
    i = np.argmax(drop, axis=1)
    rows = np.arange(len(pts))
    best = drop[rows, i]
    ok = best >= min_contrast
    il, ir = np.clip(i - 1, 0, drop.shape[1] - 1), np.clip(i + 1, 0, drop.shape[1] - 1)
    yl, yr = drop[rows, il], drop[rows, ir]
    best_f = np.where(np.isfinite(best), best, 0.0)
    yl = np.where(np.isfinite(yl), yl, best_f)
    yr = np.where(np.isfinite(yr), yr, best_f)
    den = yl - 2.0 * best_f + yr
    frac = 0.5 * (yl - yr) / np.where(den < -1e-6, den, -1.0)
    frac = np.where(den < -1e-6, frac, 0.0)
    offset = centre[i] - np.clip(frac, -1.0, 1.0) * 0.25  # steps decrease along the profile
    return pts + offset[:, None] * normals, ok


def _outward_normals(contours: list, region: np.ndarray, k: int = 3) -> np.ndarray:
    """Unit outward normals (n, 2) of the contour points (pixels of ``region``),
    from the tangent over +-``k`` neighbours along each closed contour."""
    h, w = region.shape
    out = []
    for cc in contours:
        p = cc.reshape(-1, 2).astype(float)
        tan = np.roll(p, -k, axis=0) - np.roll(p, k, axis=0)
        nrm = np.column_stack([tan[:, 1], -tan[:, 0]])
        nrm /= np.maximum(np.linalg.norm(nrm, axis=1, keepdims=True), 1e-9)
        probe = np.rint(p + 2.0 * nrm).astype(int)
        px, py = np.clip(probe[:, 0], 0, w - 1), np.clip(probe[:, 1], 0, h - 1)
        inside = region[py, px] > 0
        # one orientation for the whole contour: the one pointing out of the region more often
        if inside.mean() > 0.5:
            nrm = -nrm
        out.append(nrm)
    return np.concatenate(out)


def analyse(
    region: Region,
    cam: CameraModel,
    blocked: np.ndarray | None,
    image: np.ndarray | None = None,
    *,
    min_limb_points: int = 12,
    max_limb_rms_px: float = 2.0,
) -> Silhouette:
    """Limbs and end outlines of the pipe region seen by ``cam``; ``blocked``:
    uint8 mask (255, full image) of pixels next to the arm; ``image``: the BGR
    image, for sub-pixel edges (without it, the mask's edges are used)."""
    import cv2

    h, w = region.shape
    off = np.array([region.x0, region.y0], dtype=float)
    c, u, _, _, area = _moments_axis(region.mask)
    c = c + off
    nrm = np.array([-u[1], u[0]])
    contours, _ = cv2.findContours(region.mask, cv2.RETR_EXTERNAL, cv2.CHAIN_APPROX_NONE)
    normals = _outward_normals(contours, region.mask)
    pts = np.concatenate([cc.reshape(-1, 2) for cc in contours]).astype(float) + off
    s = (pts - c) @ u
    q = (pts - c) @ nrm
    smin, smax = float(s.min()), float(s.max())
    mh, mw = region.mask.shape
    sil = Silhouette(area, (region.x0, region.y0, int(mw), int(mh)), c, u, 0.0, (smin, smax), pts)
    ix, iy = pts[:, 0].astype(int), pts[:, 1].astype(int)
    on_border = (ix <= 1) | (iy <= 1) | (ix >= w - 2) | (iy >= h - 2)
    near_arm = blocked[iy, ix] > 0 if blocked is not None else np.zeros(len(pts), dtype=bool)
    bad = on_border | near_arm
    # half width from the points beside the axis, away from the ends
    mid = (s > smin + 0.25 * (smax - smin)) & (s < smax - 0.25 * (smax - smin)) & ~bad
    half = float(np.median(np.abs(q[mid]))) if mid.sum() >= 4 else float(np.median(np.abs(q)))
    sil.half_width = half
    end_zone = max(3.0, 2.2 * half)
    if smax - smin < 2.0 * end_zone + 4.0:
        sil.reason = "region too short for straight edges"
        return sil
    score = colour_score(image, sil.bbox) if image is not None else None
    limb_sel = (s > smin + end_zone) & (s < smax - end_zone) & ~bad
    K = cam.K
    fx, fy, cx, cy = K[0, 0], K[1, 1], K[0, 2], K[1, 2]
    for side in (1.0, -1.0):
        sel = limb_sel & (side * q > 0.3 * half)
        raw = pts[sel]
        if score is not None and len(raw):
            raw, ok = refine_edges(score[0], score[1], score[2], raw, -normals[sel])
            raw = raw[ok]
        if len(raw) < min_limb_points:
            continue
        und = undistort_points(raw, cam, pixels=True)
        line, rms = _fit_line(und)
        if rms > max_limb_rms_px:
            continue
        inside = np.append(undistort_points(c, cam, pixels=True)[0], 1.0)
        if inside @ line < 0:
            line = -line
        line = line.copy()
        if score is None:
            line[2] += 0.5  # half a pixel outward: mask contour pixels lie inside the true edge
        line_norm = np.array([line[0] * fx, line[1] * fy + line[0] * K[0, 1], line[0] * cx + line[1] * cy + line[2]])
        ss = (und - c) @ u
        d = line[:2]
        p0 = -line[2] * d  # closest point of the line to the origin
        tdir = np.array([-d[1], d[0]])
        a0, a1 = (np.array([und[np.argmin(ss)], und[np.argmax(ss)]]) - p0) @ tdir
        seg = np.array([p0 + a0 * tdir, p0 + a1 * tdir])
        sil.limbs.append(Limb(line, line_norm, rms, und, seg))
    if len(sil.limbs) < 2:
        sil.reason = "fewer than two straight edges"
    for sign, zone in ((-1, s < smin + end_zone), (1, s > smax - end_zone)):
        if (zone & bad).sum() >= 2:
            sil.hidden_ends = sil.hidden_ends + (sign,)
            continue
        raw = pts[zone]
        if score is not None and len(raw):
            ref, ok = refine_edges(score[0], score[1], score[2], raw, -normals[zone])
            raw = ref[ok]
        if len(sil.limbs) >= 2:  # the end outline: away from both straight edges
            und = undistort_points(raw, cam, pixels=True)
            dist = np.min([np.abs(und @ lb.line_px[:2] + lb.line_px[2]) for lb in sil.limbs], axis=0)
            raw = raw[dist > 1.5]
        else:
            raw = raw[np.abs((raw - c) @ nrm) < half - 1.0]
        if len(raw) < 6:
            continue
        sil.ends[sign] = undistort_points(raw, cam)
    return sil
