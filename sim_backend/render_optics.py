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
* The vehicle's two lamps beside the camera (MARIS's gripper had two 3000 lm
  LEDs; an R2-class hull carries lamps of this class): point sources with a
  ``cos^4`` beam, inverse-square fall-off and attenuation both ways. They
  make the lighting uneven: a hot spot, dark corners.
* Veiling light ``B``: a dim green-blue (pool water), ``VEIL_LEVEL`` times the
  daylight falling on a white surface at the same depth, raised by the lamps
  in proportion to the scattering ``b`` (the lamps light up the particles).
* Camera: fixed white balance set for this water at 1.5 m (operators set it
  on a grey card), auto exposure to a mean level, read noise and shot noise
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
#: Veiling light as a fraction of the daylight on a white surface at that depth.
VEIL_LEVEL = 0.22
#: Colour of the veiling light (BGR, relative): green-blue pool water.
VEIL_COLOUR_BGR = np.array([0.95, 1.0, 0.55])
#: Lamp light scattered back into the camera per unit scattering coefficient (per 1/m).
LAMP_BACKSCATTER = 0.06

#: Albedos (linear, BGR).
PIPE_ALBEDO_BGR = np.array([0.06, 0.62, 0.75])  # yellow paint
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
    lamp_power: float = 0.8
    caustics: float = 0.35

    @classmethod
    def for_visibility(cls, visibility_m: float, *, daylight: float = 1.0, lamp_power: float = 0.8, caustics: float = 0.35) -> "WaterOptics":
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
        return (VEIL_LEVEL * amb + LAMP_BACKSCATTER * self.lamp_power * self.b) * VEIL_COLOUR_BGR


@dataclass(frozen=True)
class CameraResponse:
    """Sensor and processing: white-balance gains (BGR), exposure target (mean
    linear level), gain limits, read noise and electrons per full-scale."""

    white_balance: np.ndarray
    target_mean: float = 0.30
    min_gain: float = 0.25
    max_gain: float = 16.0
    read_noise: float = 0.0008  # of full scale (about 3 DN of 4095)
    full_well_e: float = 10000.0

    @classmethod
    def for_water(cls, optics: WaterOptics, balance_range_m: float = 1.5) -> "CameraResponse":
        """White balance that makes a grey target at ``balance_range_m`` grey in
        clear pool water (absorption only), as set on a grey card by an operator."""
        t = np.exp(-WATER_ABSORPTION_BGR * 2.0 * balance_range_m)
        return cls(white_balance=(t.max() / t).astype(np.float32))


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
