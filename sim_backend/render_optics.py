"""Light in the pool water and the camera's response, for the image renderer.

The image formation model is the usual one for underwater cameras (e.g.
Akkaynak & Treibitz's revised model; Jaffe-McGlamery before it): a surface at
range ``d`` along the line of sight gives, per colour channel ``k``,

    I_k = J_k * exp(-c_k d) + B_k * (1 - exp(-c_k d))

with ``J`` the light the surface sends (albedo times the light falling on it),
``c_k`` the beam attenuation and ``B_k`` the veiling light of the water
(backscatter). Parameters and where they come from:

* ``c_k = a_k + b``: absorption of pool water per channel (pure water absorbs
  red strongly: about 0.3 / 0.06 / 0.03 1/m for broad red / green / blue
  camera bands, from Pope & Fry's pure-water spectrum) plus scattering ``b``
  by particles, the same for all channels. ``b`` follows from the scenario's
  visibility ``V`` (``vision.visibility_m[turbidity]``): the horizontal
  visibility of a dark target is about ``4.8 / c`` (Zaneveld & Pegau, 2003).
* Daylight from the surface, attenuated with depth by the diffuse attenuation
  ``K_k = a_k + DIFFUSE_SCATTER_SHARE * b`` (light scattered forward still goes
  down: ``K`` is mostly absorption), modulated on upward-facing surfaces by
  pool caustics (a moving bright web, +-35 %).
* Optional lamps beside the camera (``lamp_power``, off by default: the MARIS
  trials were pool trials in daylight at 3-4 m): point sources with a
  ``cos^4`` beam, inverse-square fall-off and attenuation both ways; they
  add a hot spot and dark corners.
* Veiling light ``B``: ``VEIL_LEVEL`` times the daylight at the camera's depth,
  further filtered by absorption over the extra path of scattered light
  (``VEIL_PATH_ATTENUATION_LENGTHS / c``, at most 8 m: bluer in clear water,
  greener in turbid water), plus lamp light scattered back in proportion to
  the scattering ``b``.
* Camera: white balance set on a grey card on the pool floor 1.5 m away (as
  operators do; auto white balance on a frame full of blue tiles would turn
  the pipe orange), auto exposure to a mean level, an optical blur of 0.6 px
  (a good lens behind a flat port, and each pixel's area), read noise and shot noise
  of a 12-bit sensor (Sony ICX445, the Mako G-125's: ~10 ke- full well), sRGB
  gamma, 8 bits.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

#: Absorption of pool water (1/m) per camera channel, BGR order.
WATER_ABSORPTION_BGR = np.array([0.03, 0.06, 0.30])
#: Visibility of a dark target is about this many attenuation lengths (Zaneveld & Pegau 2003).
VISIBILITY_ATTENUATION_LENGTHS = 4.8
#: Share of the scattering coefficient in the diffuse attenuation of daylight.
DIFFUSE_SCATTER_SHARE = 0.25
#: Extra path (in attenuation lengths) of the scattered daylight that forms the veil.
VEIL_PATH_ATTENUATION_LENGTHS = 3.0
#: Veiling light as a fraction of the daylight on a white surface at that depth.
VEIL_LEVEL = 0.22
#: Lamp light scattered back into the camera per unit scattering coefficient (per 1/m).
LAMP_BACKSCATTER = 0.06

#: Albedos (linear, BGR).
PIPE_ALBEDO_BGR = np.array([0.05, 0.69, 0.79])  # yellow paint: hue ~55 deg (OpenCV 28) in white light
TILE_ALBEDO_BGR = np.array([0.70, 0.66, 0.55])  # pale blue pool tiles
GROUT_ALBEDO_BGR = np.array([0.30, 0.30, 0.30])
ARM_ALBEDO_BGR = np.array([0.10, 0.10, 0.11])  # dark anodised aluminium
SURFACE_RADIANCE = 1.6  # the water surface seen from below, relative to daylight at depth 0


@dataclass(frozen=True)
class WaterOptics:
    """Per-channel attenuation ``c`` (1/m, BGR), scattering ``b`` (1/m), daylight
    at the surface (relative units), lamp power (same units at 1 m)."""

    c: np.ndarray
    b: float
    daylight: float = 1.0
    lamp_power: float = 0.0
    caustics: float = 0.35

    @classmethod
    def for_visibility(
        cls, visibility_m: float, *, daylight: float = 1.0, lamp_power: float = 0.0, caustics: float = 0.35
    ) -> WaterOptics:
        """Optics of water where a dark target vanishes at ``visibility_m`` (m)."""
        c_mean = VISIBILITY_ATTENUATION_LENGTHS / max(visibility_m, 0.05)
        b = max(c_mean - float(WATER_ABSORPTION_BGR.mean()), 0.0)
        return cls(WATER_ABSORPTION_BGR + b, b, daylight, lamp_power, caustics)

    def ambient_at(self, depth_m: np.ndarray | float) -> np.ndarray:
        """Daylight (BGR) reaching ``depth_m`` (m) from the surface."""
        d = np.asarray(depth_m, dtype=np.float32)[..., None]
        return (self.daylight * np.exp(-self.k_diffuse.astype(np.float32) * np.maximum(d, 0.0))).astype(np.float32)

    @property
    def k_diffuse(self) -> np.ndarray:
        """Diffuse attenuation of daylight with depth (1/m, BGR)."""
        return WATER_ABSORPTION_BGR + DIFFUSE_SCATTER_SHARE * self.b

    def veil(self, camera_depth_m: float) -> np.ndarray:
        """Veiling light ``B`` (BGR) seen by a camera at ``camera_depth_m``."""
        amb = self.daylight * np.exp(-self.k_diffuse * max(camera_depth_m, 0.0))
        path = min(VEIL_PATH_ATTENUATION_LENGTHS / float(self.c.mean()), 8.0)  # scattered light has travelled further
        return VEIL_LEVEL * amb * np.exp(-WATER_ABSORPTION_BGR * path) + LAMP_BACKSCATTER * self.lamp_power * self.b


@dataclass(frozen=True)
class CameraResponse:
    """Sensor and processing: fixed white-balance gains (BGR; None: auto, grey
    world), exposure target (mean linear level), gain limits, read noise and
    electrons per full-scale."""

    white_balance: np.ndarray | None = None
    target_mean: float = 0.30
    min_gain: float = 0.25
    max_gain: float = 16.0
    read_noise: float = 0.0008  # of full scale (about 3 DN of 4095)
    full_well_e: float = 10000.0
    #: optical blur (px, Gaussian sigma): lens and port PSF plus the pixel's own area
    blur_px: float = 0.6

    @classmethod
    def for_water(cls, optics: WaterOptics, floor_depth_m: float = 4.0, card_range_m: float = 1.5) -> CameraResponse:
        """White balance making a grey card on the floor at ``floor_depth_m``,
        ``card_range_m`` from the camera, grey in this water's daylight (clear
        water: the colour shift of absorption, not of the particles)."""
        light = optics.ambient_at(floor_depth_m).reshape(3)
        seen = light * np.exp(-WATER_ABSORPTION_BGR * card_range_m)
        return cls(white_balance=(seen[1] / seen).astype(np.float32))


def srgb_lut() -> np.ndarray:
    """Look-up table: 12-bit linear level (0..4095) -> 8-bit sRGB-encoded value."""
    x = np.arange(4096, dtype=np.float64) / 4095.0
    y = np.where(x <= 0.0031308, 12.92 * x, 1.055 * np.power(x, 1 / 2.4) - 0.055)
    return np.clip(np.round(y * 255.0), 0, 255).astype(np.uint8)


def caustic_texture(n: int = 128, seed: int = 7) -> np.ndarray:
    """A tileable (n, n) caustic pattern of mean 1 covering 1 m x 1 m: bright thin
    lines where several surface-wave refractions focus."""
    rng = np.random.default_rng(seed)
    y, x = np.mgrid[0:n, 0:n] / n
    acc = np.zeros((n, n))
    for _ in range(5):
        kx, ky = rng.integers(1, 5, size=2) * rng.choice([-1, 1], size=2)
        ph = rng.uniform(0, 2 * np.pi)
        acc += np.cos(2 * np.pi * (kx * x + ky * y) + ph)
    tex = np.exp(-np.abs(acc) * 1.5)  # sharp ridges where the sum crosses zero
    return (tex / tex.mean()).astype(np.float32)
