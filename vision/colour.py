"""Colour restoration before the colour region (MARIS: "grey world" correction).

Water absorbs red first and scatters light back into the camera: a yellow pipe
seen through a few metres of water is green or brown and washed out, and the
fixed HSV thresholds miss it. Two corrections, both per channel and global
(one look-up table for the image), configurable in :class:`ColourRestoration`:

* **veil removal** (``veil``): the light scattered by the water adds a nearly
  uniform colour to every pixel; its estimate is a low percentile of each
  channel (the darkest objects in view show little else), and a fraction
  ``veil`` of it is subtracted, then the channel is stretched back to full range
  (to its ``high_percentile``);
* **grey world** (``method: grey_world``): the scene's average colour is
  assumed grey, so each channel is scaled by ``mean / channel mean`` (gains
  limited to ``1 / max_gain .. max_gain``); near-black and clipped pixels do not
  count in the means.

The statistics come from every 4th pixel of every 4th row, so the correction
costs one pass over a sixteenth of the image plus one table look-up.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import cv2
import numpy as np

#: Restoration methods.
METHODS = ("grey_world", "none")


@dataclass(frozen=True)
class ColourRestoration:
    """Settings of :func:`restore` (see the module doc)."""

    method: str = "grey_world"
    #: largest gain (and 1 / smallest) of the grey-world correction
    max_gain: float = 3.0
    #: share of the estimated veil subtracted (0: none) ...
    veil: float = 0.5
    #: ... rising to this share in turbid water: when the darkest pixels are this bright
    #: relative to the brightest (mean over the channels), from ``turbid_ratio[0]`` to ``[1]``
    veil_turbid: float = 0.85
    turbid_ratio: tuple[float, float] = (0.7, 0.9)
    #: percentiles (of each channel) taken as the veil and as full scale
    low_percentile: float = 1.0
    high_percentile: float = 99.5
    #: hue range (OpenCV scale) left out of the grey-world means once corrected (None: keep all)
    exclude_hue: tuple[int, int] | None = (15, 42)

    def veil_share(self, ratio: float) -> float:
        """The share of the veil subtracted from an image whose darkest pixels are
        ``ratio`` times as bright as its brightest (a washed-out, turbid image: near 1)."""
        lo, hi = self.turbid_ratio
        x = float(np.clip((ratio - lo) / max(hi - lo, 1e-6), 0.0, 1.0)) if self.veil > 0 else 0.0
        return self.veil + (max(self.veil_turbid, self.veil) - self.veil) * x

    def check(self) -> list[str]:
        """Problems with the settings (empty when usable)."""
        errs = []
        if not 0.0 <= self.veil_turbid <= 1.0 or not 0.0 <= self.turbid_ratio[0] < self.turbid_ratio[1] <= 1.0:
            errs.append("colour restoration veil_turbid must be within 0-1 and turbid_ratio increasing within 0-1")
        if self.method not in METHODS:
            errs.append(f"colour restoration method must be one of {', '.join(METHODS)}, got {self.method!r}")
        if not 1.0 <= self.max_gain <= 16.0:
            errs.append(f"colour restoration max_gain must be within 1-16, got {self.max_gain}")
        if not 0.0 <= self.veil <= 1.0:
            errs.append(f"colour restoration veil must be within 0-1, got {self.veil}")
        if not 0.0 <= self.low_percentile < self.high_percentile <= 100.0:
            errs.append("colour restoration percentiles must satisfy 0 <= low < high <= 100")
        return errs


@dataclass(frozen=True)
class ColourCorrection:
    """Per-channel tables (BGR) of one image's restoration, and the gains and veil found."""

    lut: np.ndarray
    gains: np.ndarray
    veil: np.ndarray
    #: how much the restoration amplifies the image's noise (the largest per-channel slope)
    amplification: float = 1.0
    #: the table as ``restored = clip(slope * raw + offset, 0, 255)`` per channel (BGR)
    slope: np.ndarray = field(default_factory=lambda: np.ones(3, np.float32))
    offset: np.ndarray = field(default_factory=lambda: np.zeros(3, np.float32))

    @property
    def smoothing(self) -> int:
        """Odd box size (px) that brings the amplified noise back near the raw image's."""
        return int(np.clip(2 * round(self.amplification) - 1, 3, 9))

    def apply(self, bgr: np.ndarray) -> np.ndarray:
        """The restored copy of ``bgr`` (or of a crop of it)."""
        return cv2.LUT(bgr, self.lut)


def correction(bgr: np.ndarray, settings: ColourRestoration) -> ColourCorrection | None:
    """The restoration of one BGR image, or None when ``settings.method`` is ``none``
    and no veil is removed (the image is used as it is). Statistics from about
    10 000 pixels (a nearest-neighbour thumbnail), near-black and clipped ones left out."""
    if settings.method == "none" and settings.veil <= 0.0:
        return None
    h, w = bgr.shape[:2]
    step = max(1, int(np.sqrt(h * w / 10000.0)))
    small = cv2.resize(bgr, (max(1, w // step), max(1, h // step)), interpolation=cv2.INTER_NEAREST)
    b, g, r = cv2.split(small)
    lum = cv2.max(cv2.max(b, g), r)
    valid = cv2.inRange(lum, 9, 249)
    if cv2.countNonZero(valid) < 64:
        valid = np.full(lum.shape, 255, np.uint8)
    lo = np.zeros(3, np.float32)
    hi = np.full(3, 255.0, np.float32)
    if settings.veil > 0.0:
        for ch, plane in enumerate((b, g, r)):
            cdf = np.cumsum(cv2.calcHist([plane], [0], valid, [256], [0, 256]).reshape(-1))
            lo[ch] = float(np.searchsorted(cdf, settings.low_percentile / 100.0 * cdf[-1]))
            hi[ch] = float(np.searchsorted(cdf, settings.high_percentile / 100.0 * cdf[-1]))
        lo *= settings.veil_share(float(np.mean(lo / np.maximum(hi, 1.0))))
        hi = np.maximum(hi, lo + 16.0)
    gains = np.ones(3, np.float32)
    if settings.method == "grey_world":
        gains = _grey_gains(cv2.mean(small, mask=valid)[:3], lo, hi, settings.max_gain)
        if settings.exclude_hue is not None:  # again without the target's colour: a close pipe is not the scene
            hsv = cv2.cvtColor(cv2.LUT(small, _table(lo, hi, gains)), cv2.COLOR_BGR2HSV)
            h0, h1 = settings.exclude_hue
            away = cv2.bitwise_and(valid, cv2.bitwise_not(cv2.inRange(hsv, (h0, 38, 0), (h1, 255, 255))))
            if cv2.countNonZero(away) >= 0.5 * cv2.countNonZero(valid):
                gains = _grey_gains(cv2.mean(small, mask=away)[:3], lo, hi, settings.max_gain)
    slope = (255.0 * gains / (hi - lo)).astype(np.float32)
    return ColourCorrection(
        _table(lo, hi, gains), gains, lo, float(slope.max()), slope, (-lo * slope).astype(np.float32)
    )


def _grey_gains(raw_means: tuple, lo: np.ndarray, hi: np.ndarray, max_gain: float) -> np.ndarray:
    """Grey-world gains of the stretched channels from the raw channel means."""
    means = np.maximum((np.asarray(raw_means, np.float32) - lo) / (hi - lo) * 255.0, 1.0)
    return np.clip(float(means.mean()) / means, 1.0 / max_gain, max_gain).astype(np.float32)


def _table(lo: np.ndarray, hi: np.ndarray, gains: np.ndarray) -> np.ndarray:
    """The look-up table (256, 1, 3) of a stretch from ``lo..hi`` to 0..255 then ``gains``, per channel."""
    x = np.arange(256, dtype=np.float32)[:, None]
    table = np.clip((x - lo[None, :]) / (hi - lo)[None, :] * 255.0 * gains[None, :], 0, 255)
    return np.round(table).astype(np.uint8).reshape(256, 1, 3)


class RestoredImage:
    """A BGR image and its restoration, applied only to the parts asked for (a
    crop, or every other pixel): the detector looks at the pipe's surroundings,
    not at the whole frame."""

    def __init__(self, bgr: np.ndarray, corr: ColourCorrection | None):
        self.raw = bgr
        self.corr = corr
        self.shape = bgr.shape
        #: box size (px) for smoothing before colour decisions (3 unless the restoration amplified noise)
        self.smoothing = 3 if corr is None else corr.smoothing
        self._cached: tuple[int, int, int, int, np.ndarray] | None = None
        self._reduced: dict[int, np.ndarray] = {}

    def crop(self, x0: int, y0: int, x1: int, y1: int) -> np.ndarray:
        """Rows ``y0:y1``, columns ``x0:x1`` of the restored image (restored once:
        the last crop is kept and a crop inside it is a view of it)."""
        if self.corr is None:
            return self.raw[y0:y1, x0:x1]
        c = self._cached
        if c is not None and c[0] <= x0 and c[1] <= y0 and x1 <= c[2] and y1 <= c[3]:
            return c[4][y0 - c[1] : y1 - c[1], x0 - c[0] : x1 - c[0]]
        part = self.corr.apply(self.raw[y0:y1, x0:x1])
        self._cached = (x0, y0, x1, y1, part)
        return part

    def reduced(self, factor: int) -> np.ndarray:
        """The image reduced ``factor`` times (every ``factor``-th pixel, then a 3 x 3 mean), restored
        (made once per factor; the array is shared: do not write to it)."""
        done = self._reduced.get(factor)
        if done is not None:
            return done
        h, w = self.raw.shape[:2]
        small = cv2.resize(
            self.raw, ((w + factor - 1) // factor, (h + factor - 1) // factor), interpolation=cv2.INTER_NEAREST
        )
        small = small if self.corr is None else self.corr.apply(small)
        # nine samples per pixel, as an area average has, at a tenth of the cost
        done = self._reduced[factor] = cv2.blur(small, (3, 3))
        return done

    def full(self) -> np.ndarray:
        """The whole restored image."""
        return self.raw if self.corr is None else self.corr.apply(self.raw)


def restore(bgr: np.ndarray, settings: ColourRestoration) -> np.ndarray:
    """The restored BGR image (the input itself with ``method: none`` and no veil removal)."""
    c = correction(bgr, settings)
    return bgr if c is None else c.apply(bgr)
