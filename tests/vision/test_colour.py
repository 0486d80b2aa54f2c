"""Colour restoration (grey world, veil removal) and the colour region's adaptive thresholds."""

from __future__ import annotations

import cv2
import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from vision.colour import ColourRestoration, RestoredImage, correction, restore
from vision.silhouette import HsvRange, Hysteresis, hsv_mask


def scene(rng: np.random.Generator, w: int = 320, h: int = 240) -> np.ndarray:
    """A grey-ish textured floor (BGR, 8 bits) with a yellow bar across it."""
    floor = np.clip(rng.normal(120, 25, (h, w, 1)) + rng.normal(0, 4, (h, w, 3)), 0, 255)
    img = floor.astype(np.uint8)
    img[100:130, 40:280] = (30, 170, 190)  # yellow in BGR
    return img


@settings(max_examples=30, deadline=None)
@given(gains=st.tuples(st.floats(0.5, 1.0), st.floats(0.5, 1.0), st.floats(0.5, 1.0)), seed=st.integers(0, 999))
def test_grey_world_undoes_a_colour_cast(gains: tuple, seed: int) -> None:
    """A per-channel cast on a grey scene is undone: the channel means come back equal."""
    img = scene(np.random.default_rng(seed))
    cast = np.clip(img.astype(float) * np.array(gains)[None, None, :], 0, 255).astype(np.uint8)
    out = restore(cast, ColourRestoration(veil=0.0, exclude_hue=None, max_gain=4.0))
    m = out.reshape(-1, 3).astype(float).mean(axis=0)
    assert np.ptp(m) < 0.05 * m.mean(), m


def test_veil_removal_restores_the_saturation_that_turbid_water_takes() -> None:
    img = scene(np.random.default_rng(1))
    veiled = (0.35 * img.astype(float) + 0.65 * np.array([150.0, 140.0, 110.0])).astype(np.uint8)  # water's veil
    sat = lambda im: cv2.cvtColor(im, cv2.COLOR_BGR2HSV)[110:120, 60:260, 1].mean()  # noqa: E731
    plain = restore(veiled, ColourRestoration(veil=0.0))
    cleared = restore(veiled, ColourRestoration())
    assert sat(cleared) > 1.3 * sat(plain) and sat(cleared) > 1.6 * sat(veiled)


def test_veil_share_grows_with_turbidity_and_none_is_the_image_itself() -> None:
    s = ColourRestoration()
    shares = [s.veil_share(r) for r in np.linspace(0.0, 1.0, 11)]
    assert shares[0] == s.veil and shares[-1] == s.veil_turbid and np.all(np.diff(shares) >= 0)
    img = scene(np.random.default_rng(2))
    assert restore(img, ColourRestoration("none", veil=0.0)) is img
    assert ColourRestoration(method="spectral").check()


def test_restoring_a_crop_equals_cropping_the_restored_image() -> None:
    img = scene(np.random.default_rng(3))
    c = correction(img, ColourRestoration())
    assert c is not None
    r = RestoredImage(img, c)
    np.testing.assert_array_equal(r.crop(10, 20, 200, 150), c.apply(img)[20:150, 10:200])
    np.testing.assert_array_equal(r.crop(30, 40, 100, 90), c.apply(img)[40:90, 30:100])  # from the kept crop


def test_thresholds_follow_the_image_and_the_hysteresis_joins_the_weak_side() -> None:
    """A pipe whose lower half is pale (the shaded side in turbid water) stays whole."""
    img = np.full((240, 320, 3), (120, 118, 115), np.uint8)
    img[100:115, 40:280] = (40, 150, 170)  # strong yellow
    img[115:130, 40:280] = (105, 125, 130)  # pale yellow: saturation 49, under MARIS's 63
    hsv = cv2.cvtColor(img, cv2.COLOR_BGR2HSV)
    assert hsv[120, 100, 1] < 63 and 22 <= hsv[120, 100, 0] <= 35
    fixed = hsv_mask(img, HsvRange())
    adaptive = hsv_mask(img, HsvRange(), hysteresis=Hysteresis())
    assert fixed[120, 100] == 0 and adaptive[120, 100] == 255
    assert adaptive[50, 100] == 0 and adaptive[200, 300] == 0  # the grey background stays out
    h = Hysteresis()
    strong, weak = h.ranges(HsvRange(), median_sat=4.0)
    assert strong.sat_min == h.strong_floor and weak is not None and weak.sat_min == h.weak_floor
    assert weak.hue == (22 - h.hue_margin, 35 + h.hue_margin)
    strong, weak = h.ranges(HsvRange(), median_sat=12.0)
    assert (
        strong.sat_min == round(h.strong_factor * 12) and weak is not None and weak.sat_min == int(h.weak_factor * 12)
    )
    strong, _ = Hysteresis().ranges(HsvRange(), median_sat=60.0)
    assert strong.sat_min == 63  # never above MARIS's threshold
