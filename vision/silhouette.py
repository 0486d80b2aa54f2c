"""One image: the colour region of the pipe and its straight edges (pixels).

Steps, all on one (raw, distorted, colour-restored: :mod:`vision.colour`) image:

1. HSV threshold (OpenCV scales: hue 0-179, saturation and value 0-255; MARIS
   used hue 22-35, saturation >= 63, value >= 30), with thresholds that follow
   the image and a hysteresis (:class:`Hysteresis`). A hue range with
   ``lo > hi`` wraps around (for red targets).
2. The arm's reprojection mask (if any) is removed, small speckle opened away.
3. The largest connected region is the pipe; other regions lying along its
   principal axis (the pipe cut in two by the arm) join it.
4. The two long edges (limbs) are searched on profiles across the region, on
   both sides of its boundary, in a pipe-versus-background score
   (:func:`pipe_score`), with a straight-sided pipe's width as a prior
   (:func:`_limb_profiles`); each is fitted as a straight line (Huber, then
   without the outliers) in undistorted pixels.
5. The end outlines: the region's own outline in its end zones, moved to the
   score's steepest fall; profiles along the axis where the region lost the
   end (:func:`_end_profiles`). Points on the image border or next to the arm
   mask are not edges of the pipe: an end touching them is hidden.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field, replace

import cv2
import numpy as np

from vision.calibration import CameraModel, undistort_points
from vision.colour import RestoredImage


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


@dataclass(frozen=True)
class Hysteresis:
    """Saturation thresholds that follow the image, and the weak range of the hysteresis.

    In turbid water the veil desaturates everything, the pipe included, and a
    fixed saturation threshold finds nothing; the background's saturation falls
    with it. So the strong range's saturation threshold is
    ``clip(strong_factor x the image's median saturation, strong_floor, hsv.sat_min)``
    (MARIS's 63 at most), and pixels within ``hue_margin`` of the hue range with a
    saturation of at least ``clip(weak_factor x median, weak_floor, weak_max)``
    and a value >= ``val_min`` join the colour region where they connect to the
    strong pixels. ``strong_factor`` 0 keeps the strong threshold fixed; ``weak_max``
    0 disables the weak range."""

    hue_margin: int = 4
    strong_factor: float = 2.5
    strong_floor: int = 16
    weak_factor: float = 1.6
    weak_floor: int = 10
    weak_max: int = 40
    val_min: int = 30

    def ranges(self, strong: HsvRange, median_sat: float = 0.0) -> tuple[HsvRange, HsvRange | None]:
        """The strong and weak ranges for an image of median saturation ``median_sat``."""
        sat = strong.sat_min
        if self.strong_factor > 0:
            sat = int(np.clip(self.strong_factor * median_sat, min(self.strong_floor, sat), sat))
        seed = HsvRange(strong.hue, sat, strong.val_min, strong.sat_max, strong.val_max)
        if self.weak_max <= 0:
            return seed, None
        h0, h1 = strong.hue
        m = self.hue_margin
        hue = ((h0 - m) % 180, (h1 + m) % 180) if m > 0 else (h0, h1)
        weak_sat = int(np.clip(self.weak_factor * median_sat, self.weak_floor, self.weak_max))
        return seed, HsvRange(hue, min(weak_sat, sat), min(self.val_min, strong.val_min))


def colour_mask(
    image: np.ndarray | RestoredImage,
    rng: HsvRange,
    coarse_above: int = 800,
    hysteresis: Hysteresis | None = None,
) -> np.ndarray:
    """uint8 mask (255 inside the colour range) of a BGR image (or of a restored one)
    at its working resolution: images wider than ``coarse_above`` px are thresholded
    at a third (wider than 1000 px) or half of the resolution, on 3 x 3 means of
    every third or second pixel (:meth:`RestoredImage.reduced`); smaller ones at
    full resolution after a light smoothing (sensor noise makes dark pixels look
    saturated). With ``hysteresis``, the thresholds follow the image and the pixels
    of its weak range connected to the strong range join. The colour region only
    seeds the edge searches, which run on the full-resolution image."""
    img = image if isinstance(image, RestoredImage) else RestoredImage(image, None)
    hsv = cv2.cvtColor(_working_image(img, coarse_above), cv2.COLOR_BGR2HSV)
    strong, weak = rng, None
    if hysteresis is not None:
        strong, weak = hysteresis.ranges(rng, float(np.median(hsv[::4, ::4, 1])))
    return _hsv_mask(hsv, strong, weak)


@dataclass(frozen=True)
class LocalContrast:
    """The colour region from the pipe's colour against its surroundings, for images where
    no pixel has the pipe's colour itself (:func:`contrast_mask`).

    In very turbid water the veil dominates every pixel: after the restoration the
    pipe keeps the background's cast and differs from it by a few 8-bit levels, so
    its absolute hue is the water's. What remains of the pipe is the direction of
    that difference: a pixel's colour less the local background's (the image on a
    grid ``grid`` cells wide, a median over a quarter of its height: several pipe
    widths) has the pipe's hue. Pixels whose difference has a hue in the strong range and a chroma of
    ``strong_factor`` times the image's median chroma difference (its noise) seed
    the region; those within the hysteresis's hue margin at ``weak_factor`` times
    join where they connect. ``enabled`` False leaves it out."""

    enabled: bool = True
    grid: int = 64
    strong_factor: float = 3.0
    weak_factor: float = 1.8
    #: the least chroma difference (8-bit levels) of a strong pixel, whatever the noise
    min_chroma: float = 4.0
    #: a region less elongated than this (spread along its axis over across) is not looked at:
    #: a pipe in view at the ranges where the veil hides its colour is several times longer
    #: than wide; stains and the lamps' uneven light are not
    min_elongation: float = 2.5


@dataclass(frozen=True)
class UnevenLight:
    """The faint pipe looked for again under uneven light (the detector's look again, where
    its first gives no answer it reports).

    The lamps light the water in front of the camera unevenly: their backscatter is brightest
    in lobes towards the image's sides and changes over a scale near the pipe's length, which
    a median over a quarter of the image follows only in part, so the colour left against it
    varies by as much as the pipe's. Here the background is the image's smooth trend instead:
    per channel, a polynomial in x and y of degree ``degree`` fitted to the grid of
    :attr:`LocalContrast.grid` cells, ``rounds`` times again without the cells farther than
    ``clip`` robust sigmas from it (the pipe, tiles). And the pipe's colour there is often the
    water's cast (its own colour without grey does not tell it from the floor's), so where it
    separates the pipe from its surroundings by less than :data:`MIN_SCORE_CONTRAST`, the
    score runs along the colour of their difference less its grey part, down to a contrast of
    ``min_contrast`` (8-bit levels), its edge points' least fall ``min_step`` (8-bit levels
    over 2 px; :attr:`EdgeSearch.min_step`)."""

    degree: int = 4
    clip: float = 2.5
    rounds: int = 4
    min_contrast: float = 1.0
    min_step: float = 1.2

    def check(self) -> list[str]:
        """Problems with the settings (empty when usable)."""
        errs = []
        if not 1 <= self.degree <= 6:
            errs.append(f"uneven light: degree must be within 1-6, got {self.degree}")
        if self.rounds < 1 or not self.clip > 0.0:
            errs.append(f"uneven light: rounds must be >= 1 and clip > 0, got {self.rounds}, {self.clip}")
        if not (self.min_contrast > 0.0 and self.min_step > 0.0):
            errs.append(
                f"uneven light: min_contrast and min_step must be > 0, got {self.min_contrast}, {self.min_step}"
            )
        return errs


def _working_image(img: RestoredImage, coarse_above: int = 800) -> np.ndarray:
    """The (restored) image at the colour region's working resolution, lightly smoothed
    (:func:`colour_mask`)."""
    w = img.shape[1]
    f = 1 if w <= coarse_above else (3 if w > 1000 else 2)
    k = img.smoothing
    small = img.reduced(f) if f > 1 else cv2.blur(img.full(), (k, k))
    if f > 1 and k > 2 * f + 1:
        small = cv2.blur(small, (k // f | 1, k // f | 1))
    return small


def contrast_mask(
    image: np.ndarray | RestoredImage,
    rng: HsvRange,
    settings: LocalContrast = LocalContrast(),
    hysteresis: Hysteresis | None = None,
    coarse_above: int = 800,
    uneven: UnevenLight | None = None,
) -> np.ndarray:
    """uint8 mask (255 inside) at the working resolution of :func:`colour_mask` of the
    pixels whose colour differs from the local background's towards the pipe's hue
    (:class:`LocalContrast`); with ``uneven``, from the image's smooth trend instead
    (:class:`UnevenLight`)."""
    img = image if isinstance(image, RestoredImage) else RestoredImage(image, None)
    small = _working_image(img, coarse_above)
    h, w = small.shape[:2]
    cell = max(1, w // max(settings.grid, 1))
    tiny = cv2.resize(small, (max(1, w // cell), max(1, h // cell)), interpolation=cv2.INTER_AREA)
    coarse = quarter_median(tiny) if uneven is None else smooth_trend(tiny, uneven)
    bg = cv2.resize(coarse, (w, h), interpolation=cv2.INTER_LINEAR)
    # a 5 x 5 mean more (15 px at 1292 px, a fraction of the pipe's width): the differences are a few levels
    diff = cv2.subtract(cv2.blur(small, (5, 5)), bg, dtype=cv2.CV_16S)
    # the difference's hue is that of grey plus the difference; its chroma the spread of its channels
    grey_plus = cv2.add(diff, np.full(3, 128.0), dtype=cv2.CV_8U)  # saturating
    hue = cv2.cvtColor(grey_plus, cv2.COLOR_BGR2HSV)[..., 0]
    b, g, r = cv2.split(diff)
    chroma = cv2.subtract(cv2.max(cv2.max(b, g), r), cv2.min(cv2.min(b, g), r), dtype=cv2.CV_32F)
    noise = max(float(np.median(chroma[::4, ::4])), 1.0)
    strong = max(settings.strong_factor * noise, settings.min_chroma)
    scale = 255.0 / max(4.0 * strong, 1.0)  # chroma on a saturation-like 0-255 scale
    sat = np.clip(chroma * scale, 0, 255).astype(np.uint8)
    hsv = cv2.merge([hue, sat, np.full_like(hue, 255)])
    seed = HsvRange(rng.hue, int(np.ceil(strong * scale)), 0)
    weak = None
    if hysteresis is not None and hysteresis.weak_max > 0:
        m = hysteresis.hue_margin
        h0, h1 = rng.hue
        weak = HsvRange(((h0 - m) % 180, (h1 + m) % 180), int(np.ceil(settings.weak_factor * noise * scale)), 0)
    return _hsv_mask(hsv, seed, weak)


def quarter_median(image: np.ndarray) -> np.ndarray:
    """The median of a small (grid) image over a square a quarter of its smaller side (odd, at
    least 3 cells): several pipe widths, so that the pipe does not pull it where it passes."""
    k = max(3, (min(image.shape[:2]) // 4) | 1)
    return cv2.medianBlur(image, min(k, 255))


def smooth_trend(image: np.ndarray, settings: UnevenLight = UnevenLight()) -> np.ndarray:
    """The smooth trend (uint8, the same shape) of a small BGR ``image``: per channel a
    polynomial in x and y (both scaled to -1..1) of degree ``settings.degree``, fitted by least
    squares first to the image's median over a quarter of its size (a start that a pipe or a
    tile does not pull), then ``settings.rounds`` times to the image itself without the pixels
    farther from the last fit than ``settings.clip`` robust sigmas (1.4826 median absolute
    deviations, at least half a level) in any channel."""
    h, w = image.shape[:2]
    yy, xx = np.mgrid[0:h, 0:w]
    x = (xx.ravel() + 0.5) / w * 2.0 - 1.0
    y = (yy.ravel() + 0.5) / h * 2.0 - 1.0
    d = settings.degree
    A = np.stack([x**i * y**j for i in range(d + 1) for j in range(d + 1 - i)], axis=1)
    channels = image.shape[2]
    start = quarter_median(image).reshape(-1, channels).astype(np.float64)
    coef = np.linalg.lstsq(A, start, rcond=None)[0]
    values = image.reshape(-1, channels).astype(np.float64)
    for _ in range(settings.rounds):
        res = values - A @ coef
        # at least half a level: an 8-bit image holds whole levels, its spread can be 0
        sigma = np.maximum(1.4826 * np.median(np.abs(res - np.median(res, axis=0)), axis=0), 0.5)
        keep = np.all(np.abs(res) < settings.clip * sigma, axis=1)
        if keep.sum() < A.shape[1]:
            break
        coef = np.linalg.lstsq(A[keep], values[keep], rcond=None)[0]
    return np.clip(np.round(A @ coef), 0, 255).reshape(image.shape).astype(np.uint8)


def hsv_mask(
    image: np.ndarray | RestoredImage,
    rng: HsvRange,
    coarse_above: int = 800,
    hysteresis: Hysteresis | None = None,
) -> np.ndarray:
    """:func:`colour_mask` at the image's full resolution (:func:`upsampled_mask`)."""
    h, w = image.shape[:2]
    return upsampled_mask(colour_mask(image, rng, coarse_above, hysteresis), w, h)


def upsampled_mask(mask: np.ndarray, width: int, height: int) -> np.ndarray:
    """A mask of a reduced image at ``width`` x ``height`` (itself when it has that size):
    bilinear between the reduced pixels' centres (reduced pixel ``j`` sampled at
    full-resolution ``j * width / mask width``, as :meth:`RestoredImage.reduced`
    makes it), 255 where that reaches half."""
    out = np.zeros((height, width), np.uint8)
    if mask.shape == out.shape:
        return mask
    crop = _upsampled_crop(mask, width, height)
    if crop is not None:
        part, x0, y0 = crop
        out[y0 : y0 + part.shape[0], x0 : x0 + part.shape[1]] = part
    return out


def _upsampled_crop(mask: np.ndarray, width: int, height: int) -> tuple[np.ndarray, int, int] | None:
    """The bounding box of :func:`upsampled_mask` (mask, column, row); None when empty."""
    x, y, bw, bh = cv2.boundingRect(mask)
    if bw == 0:
        return None
    sx, sy = width / mask.shape[1], height / mask.shape[0]
    x0, y0 = max(int(sx * (x - 1)), 0), max(int(sy * (y - 1)), 0)
    x1, y1 = min(int(np.ceil(sx * (x + bw))) + 1, width), min(int(np.ceil(sy * (y + bh))) + 1, height)
    M = np.array([[1.0 / sx, 0.0, x0 / sx], [0.0, 1.0 / sy, y0 / sy]])
    part = cv2.warpAffine(
        mask, M, (x1 - x0, y1 - y0), flags=cv2.INTER_LINEAR | cv2.WARP_INVERSE_MAP, borderMode=cv2.BORDER_REPLICATE
    )
    return cv2.threshold(part, 127, 255, cv2.THRESH_BINARY)[1], x0, y0


def reduced_mask(mask: np.ndarray, like: np.ndarray) -> np.ndarray:
    """A full-resolution mask (e.g. the arm's) at the size of the reduced mask ``like``:
    255 where any of its pixels in a reduced pixel's footprint is set."""
    if mask.shape == like.shape:
        return mask
    area = cv2.resize(mask, (like.shape[1], like.shape[0]), interpolation=cv2.INTER_AREA)
    return cv2.threshold(area, 0, 255, cv2.THRESH_BINARY)[1]


def _in_range(hsv: np.ndarray, rng: HsvRange) -> np.ndarray:
    h0, h1 = rng.hue
    if h0 <= h1:
        return cv2.inRange(hsv, (h0, rng.sat_min, rng.val_min), (h1, rng.sat_max, rng.val_max))
    a = cv2.inRange(hsv, (h0, rng.sat_min, rng.val_min), (179, rng.sat_max, rng.val_max))
    b = cv2.inRange(hsv, (0, rng.sat_min, rng.val_min), (h1, rng.sat_max, rng.val_max))
    return cv2.bitwise_or(a, b)


def _hsv_mask(hsv: np.ndarray, rng: HsvRange, weak: HsvRange | None = None) -> np.ndarray:
    strong = _in_range(hsv, rng)
    if weak is None:
        return strong
    loose = cv2.bitwise_or(_in_range(hsv, weak), strong)
    n, labels = cv2.connectedComponentsWithAlgorithm(loose, 8, cv2.CV_32S, cv2.CCL_GRANA)
    if n <= 1:
        return strong
    kept = np.unique(labels[strong > 0])
    kept = kept[kept > 0]
    if len(kept) > 8:  # many pieces: one table look-up
        keep = np.zeros(n, np.uint8)
        keep[kept] = 255
        return keep[labels]
    out = np.zeros(loose.shape, np.uint8)
    for lab in kept:  # a few pieces (the usual case): one comparison each, cheaper than indexing
        cv2.bitwise_or(out, cv2.inRange(labels, int(lab), int(lab)), dst=out)
    return out


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
    #: median step of the pipe score across the edge (8-bit units) and its share of the pipe's contrast
    contrast: float = 0.0
    #: a weak edge: kept only if the cylinder fitted to the other edges agrees with it
    weak: bool = False
    #: which side of the region (+1 / -1 along its normal)
    side: int = 0
    #: found from the colour against the local background (:func:`contrast_mask`), not the pipe's colour
    faint: bool = False


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
    #: the pipe score the edges were searched in (None without an image)
    score: Score | None = None

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
    sub-rectangle at column ``x0``, row ``y0``; ``shape``: the full image's (h, w);
    ``pixel``: the size (px) of the pixels it was found at (its outline is that uncertain)."""

    mask: np.ndarray
    x0: int
    y0: int
    shape: tuple[int, int]
    pixel: float = 1.0

    def full(self) -> np.ndarray:
        """The region as a full-size mask."""
        out = np.zeros(self.shape, np.uint8)
        h, w = self.mask.shape
        out[self.y0 : self.y0 + h, self.x0 : self.x0 + w] = self.mask
        return out


def upsampled_region(region: Region, width: int, height: int) -> Region:
    """A region selected on a reduced mask, at ``width`` x ``height`` (:func:`upsampled_mask`)."""
    if region.shape == (height, width):
        return region
    crop = _upsampled_crop(region.full(), width, height)
    if crop is None:
        return Region(np.zeros((0, 0), np.uint8), 0, 0, (height, width))
    part, x0, y0 = crop
    return Region(part, x0, y0, (height, width), width / region.shape[1])


def select_region(mask: np.ndarray, min_area: int) -> tuple[Region | None, str]:
    """The pipe's region among the connected components of ``mask`` (None and why if none)."""
    x0, y0, bw, bh = cv2.boundingRect(mask)
    if bw == 0 or bh == 0:
        return None, "no pixel in the colour range"
    crop = mask[y0 : y0 + bh, x0 : x0 + bw]
    # Grana's block-based labelling: the same components, several times faster than the default with stats
    n, labels, stats, cents = cv2.connectedComponentsWithStatsWithAlgorithm(crop, 8, cv2.CV_32S, cv2.CCL_GRANA)
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
    if sd_along > 2.0 * sd_across:  # elongated: pieces of the same pipe on its axis line join (arm crossing)
        nrm = np.array([-u[1], u[0]])
        band = max(3.0 * sd_across, 3.0)
        for lab in order[1:]:
            if stats[lab, cv2.CC_STAT_AREA] < max(min_area // 4, 4):
                break
            if abs((cents[lab] - c) @ nrm) >= band:
                continue
            lx, ly, lw, lh = (int(v) for v in stats[lab, :4])  # the piece's own box (its spread is the same)
            if _spread_across(labels[ly : ly + lh, lx : lx + lw] == lab, nrm) <= 1.5 * sd_across + 1.0:
                keep.append(int(lab))  # (a floor tile of the pipe's colour on that line is wider than the pipe)
    if len(keep) > 1:
        comp = np.isin(labels, keep).astype(np.uint8)
    return Region(comp * 255, int(x0), int(y0), mask.shape[:2]), ""


def elongation(mask: np.ndarray) -> float:
    """The spread (standard deviation) of a mask's pixels along its principal axis over
    that across it (inf for a line, 1 for a disc)."""
    _, _, along, across, n = _moments_axis(mask)
    return float("inf") if n > 0 and across <= 1e-9 else (along / across if n > 0 else 0.0)


def _spread_across(piece: np.ndarray, nrm: np.ndarray) -> float:
    """Standard deviation (px) of a boolean mask's pixels along the unit direction ``nrm``."""
    m = cv2.moments(piece.astype(np.uint8), binaryImage=True)
    if m["m00"] <= 0:
        return 0.0
    cov = np.array([[m["mu20"], m["mu11"]], [m["mu11"], m["mu02"]]]) / m["m00"]
    return float(np.sqrt(max(float(nrm @ cov @ nrm), 0.0)))


def _fit_line(pts_px: np.ndarray) -> tuple[np.ndarray, float]:
    """Huber line fit ``(a, b, c)`` (unit normal) and rms residual (px) of inliers."""
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


@dataclass(frozen=True)
class Score:
    """A pipe-versus-background score over a crop of the image at column ``x0``,
    row ``y0``: the chroma along the pipe's own hue (the colour projected on the
    pipe's mean colour less its grey part, so that brightness alone, shadows,
    white tiles and grout lines, does not change it), 0 on the background's mean,
    ``contrast`` on the pipe's (8-bit units), lightly smoothed."""

    image: np.ndarray
    x0: int
    y0: int
    contrast: float
    #: profiles across the pipe are means of this many, 1.5 px apart along it (noisy images)
    along: int = 1
    #: the share of a sharp step's height its fall over 2 px keeps after the score's smoothing,
    #: relative to the lightest smoothing's (1 for normal images, less for noisy ones)
    fall_share: float = 1.0
    #: the score runs along the colour of the pipe's difference from its surroundings, not
    #: along its own (:class:`UnevenLight`)
    along_difference: bool = False


#: The least contrast (8-bit levels) of a :class:`Score` along the pipe's own colour.
MIN_SCORE_CONTRAST = 3.0


def pipe_score(
    image: np.ndarray | RestoredImage,
    region: Region,
    blocked: np.ndarray | None,
    pad: int,
    uneven: UnevenLight | None = None,
) -> Score | None:
    """The :class:`Score` of the (restored) image around ``region`` (grown by ``pad`` px),
    from the mean colours of the region and of a ring around it (arm pixels left
    out); None when they differ by less than :data:`MIN_SCORE_CONTRAST` along the pipe's
    colour (with ``uneven``: along the colour of their difference where that is so, down to
    ``uneven.min_contrast``). The restoration is per channel ``slope * raw + offset``
    (clipping aside), so the score is one affine projection of the raw image: computed on
    it directly, without restoring the crop."""
    img = image if isinstance(image, RestoredImage) else RestoredImage(image, None)
    H, W = img.shape[:2]
    mh, mw = region.mask.shape
    x0, y0 = max(region.x0 - pad, 0), max(region.y0 - pad, 0)
    x1, y1 = min(region.x0 + mw + pad, W), min(region.y0 + mh + pad, H)
    raw = img.raw[y0:y1, x0:x1]
    inside = np.zeros((y1 - y0, x1 - x0), np.uint8)
    inside[region.y0 - y0 : region.y0 - y0 + mh, region.x0 - x0 : region.x0 - x0 + mw] = region.mask
    # the means from every third pixel of large crops, the masks made on those pixels: the core
    # 3 px inside the region, the ring 3-9 px outside it (in the crop's pixels)
    step = 1 if raw.shape[0] * raw.shape[1] < 40000 else 3
    inside = np.ascontiguousarray(inside[::step, ::step])
    sub = np.ascontiguousarray(raw[::step, ::step])
    k_near, k_ring = 2 * int(round(3 / step)) + 1, 2 * int(round(9 / step)) + 1
    near = cv2.dilate(inside, cv2.getStructuringElement(cv2.MORPH_RECT, (k_near, k_near)))
    ring = cv2.dilate(inside, cv2.getStructuringElement(cv2.MORPH_RECT, (k_ring, k_ring)))
    ring[near > 0] = 0
    core = cv2.erode(inside, cv2.getStructuringElement(cv2.MORPH_RECT, (k_near, k_near)))
    if blocked is not None:
        ring[blocked[y0:y1:step, x0:x1:step] > 0] = 0
    if cv2.countNonZero(core) < 8:
        core = inside
    if cv2.countNonZero(ring) < 8 or cv2.countNonZero(core) < 8:
        return None
    slope = img.corr.slope if img.corr is not None else np.ones(3, np.float32)
    offset = img.corr.offset if img.corr is not None else np.zeros(3, np.float32)
    mu_p = np.clip(np.array(cv2.mean(sub, mask=core)[:3]) * slope + offset, 0, 255)
    mu_b = np.clip(np.array(cv2.mean(sub, mask=ring)[:3]) * slope + offset, 0, 255)
    chroma = mu_p - mu_p.mean()  # the pipe's colour without its brightness
    norm = float(np.linalg.norm(chroma))
    least, along_difference = MIN_SCORE_CONTRAST, False
    if uneven is not None and (norm < 1e-6 or float((mu_p - mu_b) @ chroma) / norm < MIN_SCORE_CONTRAST):
        # the pipe's own colour is the water's cast: the colour of its difference from the ring
        diff = mu_p - mu_b
        chroma, least, along_difference = diff - diff.mean(), uneven.min_contrast, True
        norm = float(np.linalg.norm(chroma))
    if norm < 1e-6:
        return None
    w = (chroma / norm).astype(np.float32)
    contrast = float((mu_p - mu_b) @ w)
    if contrast < least:
        return None
    wr = w * slope  # the projection of the restored colour, on the raw one
    m = np.array([[wr[0], wr[1], wr[2], float(w @ offset) - float(w @ mu_b)]], np.float32)
    score = cv2.transform(raw.astype(np.float32), m).reshape(raw.shape[:2])
    sigma = 0.8 if img.smoothing <= 3 else 0.4 * img.smoothing  # more noise, more smoothing (edges stay put)
    k = 2 * int(np.ceil(2.5 * sigma)) + 1
    along = 1 if img.smoothing <= 3 else img.smoothing  # the edges are straight: average along them
    # a step's fall over 2 px after a Gaussian of sigma: erf(1 / (sigma sqrt 2)) of its height
    share = math.erf(1.0 / (sigma * math.sqrt(2.0))) / math.erf(1.0 / (0.8 * math.sqrt(2.0)))
    blurred = cv2.GaussianBlur(score, (k, k), sigma)
    return Score(blurred, int(x0), int(y0), contrast, along, min(share, 1.0), along_difference)


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
    if len(pts) == 0:
        return pts, np.zeros(0, bool)
    span = float(np.ceil(reach)) + 1.0
    steps = np.arange(span, -span - 0.01, -0.25, dtype=np.float32)  # px along the inward normal, inside to outside
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


def _outward_normals(contours: Sequence[np.ndarray], region: np.ndarray, k: int = 3) -> np.ndarray:
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


@dataclass(frozen=True)
class EdgeSearch:
    """Settings of the limb search (pixels at the calibrated resolution, score in 8-bit units)."""

    #: profiles across the region, at most this many along it
    stations: int = 56
    #: a limb point is a fall of the score of at least this (absolute) ...
    min_step: float = 2.5
    #: ... and this share of the pipe's contrast (falls measured over 2 px)
    min_step_share: float = 0.1
    #: a limb whose median fall is below this share of the contrast is weak
    strong_share: float = 0.2
    #: the width prior: a fall is looked for this far (share of the width + 2 px) from where
    #: the other side and the pipe's straight width predict it
    width_tolerance: float = 0.12
    #: ends: search profiles along the axis (True) or refine the colour region's own outline
    end_profiles: bool = True
    #: a limb found where the score crosses half its levels is moved out by this (px): a lit
    #: cylinder darkens towards its limbs (the surface turns from the light), so under the
    #: optics' blur the half level lies inside its silhouette (0.1-0.6 px for a blur of 0.7-1.3
    #: px and a third to two thirds of ambient light, tests/vision/test_limb_position.py); with
    #: a known radius the depth from the apparent width is too far by as much without it
    limb_inset_px: float = 0.35
    #: a side whose falls are not on one straight line is searched again along the line where
    #: they add up most, on profiles that are means of at least this many, 1.5 px apart along
    #: the pipe (more where the restoration amplified the noise: :attr:`Score.along`)
    line_search_along: int = 5


def _limb_profiles(
    score: Score,
    region: Region,
    blocked: np.ndarray | None,
    c: np.ndarray,
    u: np.ndarray,
    nrm: np.ndarray,
    s_lo: float,
    s_hi: float,
    half: float,
    cfg: EdgeSearch,
) -> dict[int, tuple[np.ndarray, np.ndarray]]:
    """Edge points (raw px) and their score falls on each side (+1, -1) of the region:
    the score sampled on profiles across the region's axis, searched on both sides
    of the region's own boundary (an edge the colour region lost lies outside it),
    then again near where the other side and a straight-sided pipe put it."""
    n_st = int(max(8, min(cfg.stations, (s_hi - s_lo) / 3.0)))
    ss = np.linspace(s_lo, s_hi, n_st, dtype=np.float32)
    Q = float(max(2.6 * half, half + 14.0))
    qs = np.arange(-Q, Q + 0.01, 0.5, dtype=np.float32)
    X = (c[0] + ss[:, None] * u[0] + qs[None, :] * nrm[0]).astype(np.float32)
    Y = (c[1] + ss[:, None] * u[1] + qs[None, :] * nrm[1]).astype(np.float32)
    nan = float("nan")
    prof = cv2.remap(
        score.image, X - score.x0, Y - score.y0, cv2.INTER_LINEAR, borderMode=cv2.BORDER_CONSTANT, borderValue=nan
    )
    inside = (
        cv2.remap(
            region.mask, X - region.x0, Y - region.y0, cv2.INTER_NEAREST, borderMode=cv2.BORDER_CONSTANT, borderValue=0
        )
        > 0
    )
    bad = np.zeros_like(inside)
    if blocked is not None:
        bad = cv2.remap(blocked, X, Y, cv2.INTER_NEAREST, borderMode=cv2.BORDER_CONSTANT, borderValue=0) > 0
    H, W = region.shape
    bad |= (X < 1.5) | (Y < 1.5) | (X > W - 2.5) | (Y > H - 2.5)
    deriv = np.full_like(prof, nan)
    deriv[:, 2:-2] = prof[:, 4:] - prof[:, :-4]  # change over 2 px, centred: blurred edges still stand out
    # the region's extent per profile, where the score looks like the pipe's (above half its contrast)
    # when it does anywhere: a region that leaked into a pipe-coloured tile or shadow beside the pipe
    # would otherwise put the search window beyond the pipe's edge
    like_pipe: np.ndarray = inside & (prof >= 0.5 * score.contrast)
    inside = np.where(np.any(like_pipe, axis=1)[:, None], like_pipe, inside)
    any_in = inside.any(axis=1)
    idx = np.arange(len(qs))
    b_hi = np.where(any_in, np.max(np.where(inside, idx[None, :], -1), axis=1), -1)
    b_lo = np.where(any_in, np.min(np.where(inside, idx[None, :], len(qs)), axis=1), len(qs))
    floor = max(cfg.min_step, cfg.min_step_share * score.contrast) * score.fall_share
    rows = np.arange(n_st)

    def pick(side: int, lo: np.ndarray, hi: np.ndarray, deriv: np.ndarray = deriv) -> tuple[np.ndarray, np.ndarray]:
        """Per station: position (q, px) and size of the largest outward fall within [lo, hi] (sample indices)."""
        fall = -side * deriv
        win = (idx[None, :] >= lo[:, None]) & (idx[None, :] <= hi[:, None])
        f = np.where(win & np.isfinite(fall), fall, -np.inf)
        k = np.argmax(f, axis=1)
        best = f[rows, k]
        kl, kr = np.clip(k - 1, 0, len(qs) - 1), np.clip(k + 1, 0, len(qs) - 1)
        best0 = np.where(np.isfinite(best), best, 0.0)
        yl = np.where(np.isfinite(f[rows, kl]), f[rows, kl], best0)
        yr = np.where(np.isfinite(f[rows, kr]), f[rows, kr], best0)
        den = yl - 2.0 * best0 + yr
        frac = np.where(den < -1e-6, 0.5 * (yl - yr) / np.where(den < -1e-6, den, -1.0), 0.0)
        q = qs[k] + 0.5 * np.clip(frac, -1.0, 1.0)
        near_bad = (
            bad[rows, k]
            | bad[rows, np.clip(k + side * 4, 0, len(qs) - 1)]
            | bad[rows, np.clip(k - side * 4, 0, len(qs) - 1)]
        )
        best = np.where(near_bad | ~np.isfinite(best), -np.inf, best)
        return q, best

    width_px = np.maximum((b_hi - b_lo) * 0.5, 1.0)
    reach = np.round(np.maximum(6.0, 0.9 * width_px) / 0.5).astype(int)  # samples
    inward = int(round((3.0 + 1.5 * (region.pixel - 1.0)) / 0.5))  # samples inside the region's outline
    q_p, f_p = pick(1, b_hi - inward, b_hi + reach)
    q_m, f_m = pick(-1, b_lo - reach, b_lo + inward)
    ok_p, ok_m = (f_p >= floor) & any_in, (f_m >= floor) & any_in
    both = ok_p & ok_m
    if both.sum() >= 6:  # the width prior: a straight-sided pipe's image width is linear along its axis
        width = q_p - q_m
        A = np.column_stack([np.ones(both.sum()), ss[both]])
        coef = np.linalg.lstsq(A, width[both], rcond=None)[0]
        for _ in range(2):
            res = width[both] - A @ coef
            keep = np.abs(res) <= max(2.0, 2.5 * 1.4826 * float(np.median(np.abs(res - np.median(res)))))
            if keep.sum() >= 4:
                coef = np.linalg.lstsq(A[keep], width[both][keep], rcond=None)[0]
        w_pred = (coef[0] + coef[1] * ss).astype(np.float32)
        tol = np.round((cfg.width_tolerance * np.abs(w_pred) + 2.0) / 0.5).astype(int)
        strong_cut = cfg.strong_share * score.contrast
        off = (np.abs(width - w_pred) > cfg.width_tolerance * np.abs(w_pred) + 2.0) | ~both
        # a side that is weak, missing, or makes the width wrong is searched again where the other side predicts it
        for side in (1, -1):
            other_q, other_f = (q_m, f_m) if side == 1 else (q_p, f_p)
            mine_f = f_p if side == 1 else f_m
            redo = (other_f >= max(floor, strong_cut)) & (off | (mine_f < strong_cut))
            if not redo.any():
                continue
            centre = np.round((other_q + side * w_pred + Q) / 0.5).astype(int)
            q2, f2 = pick(side, centre - tol, centre + tol)
            better = redo & (f2 >= floor)
            if side == 1:
                q_p, f_p = np.where(better, q2, q_p), np.where(better, f2, np.where(redo, -np.inf, f_p))
            else:
                q_m, f_m = np.where(better, q2, q_m), np.where(better, f2, np.where(redo, -np.inf, f_m))
    redone: dict[int, np.ndarray] = {}
    # noisy images and faint edges (block noise beside the edge, a shaded limb a few levels from the
    # background): a side whose falls are not on one straight line is searched again within 2 px of
    # the line along which the falls add up most (a matched filter along the pipe's length), on
    # profiles averaged over several 1.5 px apart along the axis; the new points replace the old
    # where more of them lie on one line (the search window holds the line the old points
    # scatter about only when that is near the region's outline)
    line_tol = 2.0  # px
    redo_sides: dict[int, int] = {}  # side: its points within line_tol of their line
    n_along = max(score.along, cfg.line_search_along)
    if n_along > 1:
        for side, q, f in ((1, q_p, f_p), (-1, q_m, f_m)):
            ok = (f >= floor) & any_in
            on_line, n = _on_a_line(ss[ok], q[ok], line_tol), int(ok.sum())
            if (on_line / n if n else 0.0) < 0.6:
                redo_sides[side] = on_line
    if redo_sides:
        d = ((np.arange(n_along) - 0.5 * (n_along - 1)) * 1.5).astype(np.float32)
        XS = (X[None] + d[:, None, None] * np.float32(u[0])).reshape(-1, X.shape[1])
        YS = (Y[None] + d[:, None, None] * np.float32(u[1])).reshape(-1, X.shape[1])
        many = cv2.remap(
            score.image, XS - score.x0, YS - score.y0, cv2.INTER_LINEAR, borderMode=cv2.BORDER_CONSTANT, borderValue=nan
        )
        prof_a = many.reshape(n_along, *X.shape).mean(axis=0)
        deriv_a = np.full_like(prof_a, nan)
        deriv_a[:, 2:-2] = prof_a[:, 4:] - prof_a[:, :-4]
        for side in redo_sides:
            lo, hi = (b_hi - inward, b_hi + reach) if side == 1 else (b_lo - reach, b_lo + inward)
            fall = np.where(np.isfinite(deriv_a), -side * deriv_a, 0.0)
            win = (
                np.asarray(any_in, dtype=bool)[:, None] & (idx[None, :] >= lo[:, None]) & (idx[None, :] <= hi[:, None])
            )
            cols = np.nonzero(win.any(axis=0))[0]
            if len(cols) == 0:
                continue
            c0, c1 = int(cols[0]), int(cols[-1]) + 1  # the searched samples only
            centre = _matched_line(np.where(win, fall, 0.0)[:, c0:c1], ss, 0.5)
            if centre is None:
                continue
            w_tol = int(round(line_tol / 0.5))
            q2, f2 = pick(side, centre + c0 - w_tol, centre + c0 + w_tol, deriv_a)
            ok2 = (f2 >= floor) & any_in
            if _on_a_line(ss[ok2], q2[ok2], line_tol) < redo_sides[side]:
                continue
            redone[side] = prof_a
            if side == 1:
                q_p, f_p = q2, f2
            else:
                q_m, f_m = q2, f2
    out: dict[int, tuple[np.ndarray, np.ndarray]] = {}
    for side, q, f in ((1, q_p, f_p), (-1, q_m, f_m)):
        ok = (f >= floor) & any_in
        q = _mid_crossing(redone.get(side, prof), qs, q, side)
        pts = np.column_stack([c[0] + ss[ok] * u[0] + q[ok] * nrm[0], c[1] + ss[ok] * u[1] + q[ok] * nrm[1]])
        out[side] = (pts.astype(np.float64), f[ok].astype(np.float64))
    return out


def _on_a_line(s: np.ndarray, q: np.ndarray, tol: float) -> int:
    """How many of the points ``(s, q)`` lie within ``tol`` of the line fitted to them (least
    squares, then again without those beyond 2.5 robust sigmas); 0 for fewer than six."""
    if len(s) < 6:
        return 0
    A = np.column_stack([np.ones(len(s)), s])
    coef = np.linalg.lstsq(A, q, rcond=None)[0]
    res = q - A @ coef
    keep = np.abs(res) <= max(2.5 * 1.4826 * float(np.median(np.abs(res))), tol)
    if keep.sum() >= 3:
        coef = np.linalg.lstsq(A[keep], q[keep], rcond=None)[0]
    return int(np.count_nonzero(np.abs(q - A @ coef) <= tol))


def _matched_line(fall: np.ndarray, ss: np.ndarray, step: float, max_slope: float = 0.2) -> np.ndarray | None:
    """Per station (rows of ``fall``, at axis positions ``ss``, px), the sample index of the
    straight line across the stations (within ``max_slope`` of the axis) along which
    ``fall`` (samples ``step`` px apart, 0 where not searched) adds up most: slopes on a
    grid of 21 (on the falls spread along the profiles), then 21 finer ones about the best.
    None when nothing adds up."""
    n, m = fall.shape
    if n < 6:
        return None
    s_rel = (ss - 0.5 * (ss[0] + ss[-1])) / step  # samples per unit slope
    pad = int(np.ceil(max_slope * float(np.abs(s_rel).max()))) + 2
    padded = np.zeros((n, m + 2 * pad))
    padded[:, pad : pad + m] = fall
    grid = np.linspace(-max_slope, max_slope, 21)

    def best_of(rows: np.ndarray, s_r: np.ndarray, slopes: np.ndarray) -> tuple[float, float, int]:
        """The largest sum over the stations along one of ``slopes``, that slope and the
        sample where the line starts: the first of equal sums, (-1, 0, 0) if none is above -1."""
        shifts = np.round(slopes[:, None] * s_r[None, :]).astype(int)  # (slopes, stations)
        # each (slope, station) takes the m samples of its station's row from pad + shift on:
        # whole windows of the flat rows (one copy each), not one index per sample
        starts = np.arange(len(s_r))[None, :] * rows.shape[1] + pad + shifts
        windows = np.lib.stride_tricks.sliding_window_view(np.ascontiguousarray(rows).reshape(-1), m)
        totals = windows[starts].sum(axis=1)  # (slopes, samples)
        k, j = np.unravel_index(int(np.argmax(totals)), totals.shape)
        if not totals[k, j] > -1.0:
            return -1.0, 0.0, 0
        return float(totals[k, j]), float(slopes[k]), int(j)

    # the coarse grid on falls spread over 7 samples: its lines are up to half a step of slope off
    spread = np.asarray(cv2.blur(padded.astype(np.float32), (7, 1)), dtype=float)
    _, slope0, _ = best_of(spread, s_rel, grid)
    finer = np.clip(slope0 + np.linspace(-1.0, 1.0, 21) * (grid[1] - grid[0]), -max_slope, max_slope)
    total, slope, j = best_of(padded, s_rel, finer)
    if total <= 0.0:
        return None
    return np.clip(j + np.round(slope * s_rel).astype(int), 0, m - 1)


def _end_profiles(
    score: Score,
    blocked: np.ndarray | None,
    shape: tuple[int, int],
    c: np.ndarray,
    u: np.ndarray,
    nrm: np.ndarray,
    sides: dict[int, np.ndarray],
    sign: int,
    smin: float,
    smax: float,
    cfg: EdgeSearch,
) -> tuple[np.ndarray, bool]:
    """Outline points (raw px) of the pipe's end on side ``sign`` of the region: the
    score sampled along the axis, outwards, at positions spread between the two
    limbs (``sides``: their edge points), searched from inside the region to well
    beyond it (the colour region may stop short of the end). Returns the points and
    whether the end is hidden (the profiles run into the image border or the arm)."""
    lines = {}
    for side, P in sides.items():  # each limb as q(s), in the region's own axes
        ss, qq = (P - c) @ u, (P - c) @ nrm
        lines[side] = np.polyfit(ss, qq, 1)
    s_end = smax if sign > 0 else smin
    q_hi, q_lo = float(np.polyval(lines[1], s_end)), float(np.polyval(lines[-1], s_end))
    width = q_hi - q_lo
    if width <= 4.0:
        return np.zeros((0, 2)), False
    lateral = np.linspace(q_lo + 0.12 * width, q_hi - 0.12 * width, 13, dtype=np.float32)
    step = 0.5
    along = np.arange(-0.9 * width - 4.0, 0.6 * width + 8.0, step, dtype=np.float32)  # outward from s_end
    S = s_end + sign * along
    X = (c[0] + S[None, :] * u[0] + lateral[:, None] * nrm[0]).astype(np.float32)
    Y = (c[1] + S[None, :] * u[1] + lateral[:, None] * nrm[1]).astype(np.float32)
    prof = cv2.remap(
        score.image,
        X - score.x0,
        Y - score.y0,
        cv2.INTER_LINEAR,
        borderMode=cv2.BORDER_CONSTANT,
        borderValue=float("nan"),
    )
    H, W = shape
    bad = (X < 1.5) | (Y < 1.5) | (X > W - 2.5) | (Y > H - 2.5)
    if blocked is not None:
        bad |= cv2.remap(blocked, X, Y, cv2.INTER_NEAREST, borderMode=cv2.BORDER_CONSTANT, borderValue=0) > 0
    fall = np.full_like(prof, np.nan)
    fall[:, 2:-2] = prof[:, :-4] - prof[:, 4:]  # pipe (inside) to background (outside), over 2 px
    fall = np.where(np.isfinite(fall), fall, -np.inf)
    floor = max(cfg.min_step, cfg.min_step_share * score.contrast)
    best = fall.max(axis=1)
    usable = np.isfinite(best) & (best >= floor)
    k = _outer_falls(prof, fall, np.maximum(floor, 0.35 * np.where(usable, best, 0.0)), score.contrast)
    near = np.clip(k[:, None] + np.arange(-6, 7)[None, :], 0, prof.shape[1] - 1)
    at_bad = bad[np.arange(len(k))[:, None], near].any(axis=1)  # the fall next to the border or the arm
    hidden = int((~usable & bad.any(axis=1)).sum() + (usable & at_bad).sum()) >= 4
    rows = np.nonzero(usable & ~at_bad)[0]
    picks = along[k[rows]]
    if not len(rows):
        return np.zeros((0, 2)), hidden
    q = _mid_crossing(prof[rows], along, picks.astype(np.float32), 1)
    sp = s_end + sign * q.astype(np.float64)
    lat = lateral[rows].astype(np.float64)
    return c[None, :] + sp[:, None] * u[None, :] + lat[:, None] * nrm[None, :], hidden


def _outer_falls(prof: np.ndarray, fall: np.ndarray, least: np.ndarray, contrast: float) -> np.ndarray:
    """Per profile (rows of ``prof``, running from inside the pipe outwards, and of its
    ``fall``), the index of the outermost fall (a local maximum of at least ``least``)
    that leaves the pipe for the background: pipe-like before it (the mean 2-5 px
    before, above a third of the contrast), background-like after it (the mean
    2-5 px after, below half the level before). A cap's inner rim (pipe to pipe) and a
    shadow's edge (background to shadow) are not it. The largest fall when none qualifies."""
    n = prof.shape[1]
    finite = np.isfinite(prof)
    csum = np.zeros((prof.shape[0], n + 1))
    ccnt = np.zeros((prof.shape[0], n + 1))
    csum[:, 1:] = np.cumsum(np.where(finite, prof, 0.0), axis=1)
    ccnt[:, 1:] = np.cumsum(finite, axis=1)
    k = np.arange(n)
    lo_b, hi_b = np.maximum(k - 10, 0), np.maximum(k - 3, 1)  # 7 samples before (2-5 px at 0.5 px)
    lo_a, hi_a = np.minimum(k + 4, n - 1), np.minimum(k + 11, n)  # and after
    n_b, n_a = ccnt[:, hi_b] - ccnt[:, lo_b], ccnt[:, hi_a] - ccnt[:, lo_a]
    with np.errstate(invalid="ignore", divide="ignore"):
        before = (csum[:, hi_b] - csum[:, lo_b]) / n_b
        after = (csum[:, hi_a] - csum[:, lo_a]) / n_a
    peak = (
        (fall >= least[:, None])
        & (fall >= np.roll(fall, 1, axis=1))
        & (fall >= np.roll(fall, -1, axis=1))
        & np.isfinite(fall)
    )
    good = peak & (n_b > 0) & (n_a > 0) & (before >= contrast / 3.0) & (after <= 0.5 * before)
    last = n - 1 - np.argmax(good[:, ::-1], axis=1)
    return np.where(good.any(axis=1), last, np.argmax(fall, axis=1))


def _row_nanmean(x: np.ndarray) -> np.ndarray:
    """The mean of each row of ``x`` (n, m) over its samples that are not NaN, NaN for a row
    of NaNs, in ``x``'s dtype: ``np.nanmean(x, axis=1)`` without its warning (the detector
    runs in a driver thread, and silencing warnings is process-wide)."""
    valid = ~np.isnan(x)
    total = np.where(valid, x, 0).sum(axis=1)
    with np.errstate(invalid="ignore", divide="ignore"):
        return (total / valid.sum(axis=1)).astype(x.dtype)


def _mid_crossing(prof: np.ndarray, qs: np.ndarray, q: np.ndarray, side: int) -> np.ndarray:
    """Per profile, where the score crosses halfway between its level 2-5 px inside
    the edge found at ``q`` and 2-5 px outside it (within 2.5 px of ``q``): a blurred
    or block-compressed step has its steepest point anywhere on its slope, its
    middle stays put. ``q`` where there is no crossing."""
    n, m = prof.shape
    step = float(qs[1] - qs[0])
    k = np.clip(np.round((q - qs[0]) / step).astype(int), 0, m - 1)
    rows = np.arange(n)[:, None]
    near = np.arange(4, 11)[None, :]  # 2-5 px
    inner = np.clip(k[:, None] - side * near, 0, m - 1)
    outer = np.clip(k[:, None] + side * near, 0, m - 1)
    # a profile all outside the image has no level (NaN): no crossing
    level = 0.5 * (_row_nanmean(prof[rows, inner]) + _row_nanmean(prof[rows, outer]))
    span = np.arange(-5, 6)[None, :]  # +-2.5 px
    idx = np.clip(k[:, None] + span, 0, m - 2)
    a = prof[rows, idx] - level[:, None]
    b = prof[rows, idx + 1] - level[:, None]
    cross = (a * b <= 0) & (a != b)
    with np.errstate(invalid="ignore", divide="ignore"):
        frac = np.where(cross, a / (a - b), np.nan)
    pos = qs[idx] + step * frac
    dist = np.where(cross, np.abs(pos - q[:, None]), np.inf)
    j = np.argmin(dist, axis=1)
    best = pos[np.arange(n), j]
    return np.where(np.isfinite(dist[np.arange(n), j]) & np.isfinite(best), best, q)


def analyse(
    region: Region,
    cam: CameraModel,
    blocked: np.ndarray | None,
    image: np.ndarray | RestoredImage | None = None,
    *,
    min_limb_points: int = 10,
    max_limb_rms_px: float = 3.0,
    search: EdgeSearch = EdgeSearch(),
    uneven: UnevenLight | None = None,
) -> Silhouette:
    """Limbs and end outlines of the pipe region seen by ``cam``; ``blocked``:
    uint8 mask (255, full image) of pixels next to the arm; ``image``: the
    (restored) BGR image, for the edges (without it, the mask's own edges are used);
    ``uneven``: a faint pipe's region under uneven light (its score and least edge fall,
    :class:`UnevenLight`)."""
    h, w = region.shape
    off = np.array([region.x0, region.y0], dtype=float)
    c, u, _, sd_across, area = _moments_axis(region.mask)
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
    # half width from the outline's points beside the axis, away from the ends
    mid = (s > smin + 0.25 * (smax - smin)) & (s < smax - 0.25 * (smax - smin)) & ~bad
    half = float(np.median(np.abs(q[mid]))) if mid.sum() >= 4 else float(np.median(np.abs(q)))
    sil.half_width = half
    end_zone = max(3.0, 2.2 * half)
    if smax - smin < 2.0 * end_zone + 4.0:
        sil.reason = "region too short for straight edges"
        return sil
    score = pipe_score(image, region, blocked, int(2.6 * half + 24), uneven) if image is not None else None
    sil.score = score
    if uneven is not None and score is not None and score.along_difference:
        search = replace(search, min_step=uneven.min_step)
    K = cam.K
    fx, fy, cx, cy = K[0, 0], K[1, 1], K[0, 2], K[1, 2]
    centre_und = np.append(undistort_points(c, cam, pixels=True)[0], 1.0)
    if score is not None:
        # the profiles reach at least as far as a band with the pixels' spread across the axis
        # (sqrt(3) x their standard deviation): in a region in pieces along the pipe (a faint
        # pipe's) every piece's ends put outline points near the axis, and the outline's half
        # width alone would cut the profiles short of the edges
        reach_half = max(half, float(np.sqrt(3.0)) * sd_across)
        found = _limb_profiles(score, region, blocked, c, u, nrm, smin + end_zone, smax - end_zone, reach_half, search)
    else:  # the mask's own contour, half a pixel outward
        limb_sel = (s > smin + end_zone) & (s < smax - end_zone) & ~bad
        found = {}
        for side in (1, -1):
            sel = limb_sel & (side * q > 0.3 * half)
            found[side] = (pts[sel] + 0.5 * normals[sel], np.full(int(sel.sum()), 255.0))
    for side in (1, -1):
        raw, falls = found[side]
        if len(raw) < min_limb_points:
            continue
        und = undistort_points(raw, cam, pixels=True)
        line, rms = _fit_line(und)
        if rms > max_limb_rms_px:
            continue
        if centre_und @ line < 0:
            line = -line
        line = line.copy()
        res = np.abs(und @ line[:2] + line[2])
        keep = res <= max(3.0 * rms, 1.0)
        und, falls = und[keep], falls[keep]
        if score is not None and search.limb_inset_px:  # the shaded limb's half level lies inside the edge
            line[2] += search.limb_inset_px
            und = und - search.limb_inset_px * line[:2]
        line_norm = np.array([line[0] * fx, line[1] * fy + line[0] * K[0, 1], line[0] * cx + line[1] * cy + line[2]])
        ss_ = (und - c) @ u
        d = line[:2]
        p0 = -line[2] * d  # closest point of the line to the origin
        tdir = np.array([-d[1], d[0]])
        a0, a1 = (np.array([und[np.argmin(ss_)], und[np.argmax(ss_)]]) - p0) @ tdir
        seg = np.array([p0 + a0 * tdir, p0 + a1 * tdir])
        contrast = float(np.median(falls)) if len(falls) else 0.0
        weak = score is not None and contrast < search.strong_share * score.contrast
        sil.limbs.append(Limb(line, line_norm, rms, und, seg, contrast, weak, side))
    if len(sil.limbs) < 2:
        sil.reason = "fewer than two straight edges"
    sides = {lb.side: found[lb.side][0] for lb in sil.limbs} if score is not None else {}
    for sign, zone in ((-1, s < smin + end_zone), (1, s > smax - end_zone)):
        if (zone & bad).sum() >= 2:
            sil.hidden_ends = sil.hidden_ends + (sign,)
            continue
        # the colour region's own outline, moved to the score's steepest fall nearby; where
        # the region lost part of the end (most of its outline finds no edge), profiles instead
        raw = pts[zone]
        intact = True
        if score is not None and len(raw):
            ref, ok = refine_edges(
                score.image,
                score.x0,
                score.y0,
                raw,
                -normals[zone],
                max(search.min_step, 0.15 * score.contrast),
                4.0 + 1.5 * (region.pixel - 1.0),
            )
            intact = bool(ok.mean() >= 0.8)
            raw = ref[ok]
        if len(sil.limbs) >= 2:  # the end outline: away from both straight edges
            und = undistort_points(raw, cam, pixels=True)
            dist = np.min([np.abs(und @ lb.line_px[:2] + lb.line_px[2]) for lb in sil.limbs], axis=0)
            raw = raw[dist > 1.5]
        else:
            raw = raw[np.abs((raw - c) @ nrm) < half - 1.0]
        if score is not None and len(sides) == 2 and search.end_profiles and (not intact or len(raw) < 12):
            raw, hidden = _end_profiles(score, blocked, region.shape, c, u, nrm, sides, sign, smin, smax, search)
            if hidden:
                sil.hidden_ends = sil.hidden_ends + (sign,)
                continue
        if len(raw) < 6:
            continue
        sil.ends[sign] = undistort_points(raw, cam)
    return sil
