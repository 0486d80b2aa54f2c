"""The independent evaluation set: its rig files, its truth, its splits."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from sim_backend.evalset import (
    PLAN,
    SPLIT_SEEDS,
    View,
    eval_rig,
    load_view,
    make_view,
    pipe_contrast,
    plan,
    save_view,
    write_rig_files,
)
from vision.calibration import load_stereo_calibration, project_points


def test_the_rig_reaches_the_detector_as_ros_camera_info_files(tmp_path: Path) -> None:
    rig = eval_rig()
    got = load_stereo_calibration(*write_rig_files(rig, tmp_path))
    for a, b in ((got.left, rig.left), (got.right, rig.right)):
        np.testing.assert_allclose(a.K, b.K, atol=1e-9)
        np.testing.assert_allclose(a.D, b.D, atol=1e-12)
    np.testing.assert_allclose(got.R, rig.R, atol=1e-9)
    np.testing.assert_allclose(got.T, rig.T, atol=1e-9)


def test_the_plan_covers_every_condition_and_the_splits_differ() -> None:
    p = plan("eval")
    assert len(p) == sum(n for *_, n, _ in PLAN)
    assert {(w, k) for _, k, w, _ in p} == {(w, k) for w, k, _, _ in PLAN}
    assert all(0.9 <= r <= 2.5 for *_, r in p)
    assert len(plan("tune", 0.01)) == len(PLAN)  # at least one view per row
    assert plan("tune2") == p  # the development splits follow the same plan


def test_the_splits_never_share_a_seed_and_an_unknown_split_is_refused() -> None:
    assert {"eval", "tune", "tune2"} <= set(SPLIT_SEEDS)
    assert len(set(SPLIT_SEEDS.values())) == len(SPLIT_SEEDS)
    with pytest.raises(ValueError, match="unknown evaluation split 'tune3'"):
        make_view(0, "pipe", "clear", 1.2, "tune3")


@pytest.mark.slow
def test_rendered_truth_matches_the_images(tmp_path: Path) -> None:
    """The pipe's truth projects onto the pipe's pixels; a pipe-free view has none;
    a saved view reads back the same; the two splits render different images."""
    rig = eval_rig()
    v = make_view(3, "pipe", "clear", 1.2, "eval", rig)
    assert v.left.shape == (rig.left.height, rig.left.width, 3) and v.left.dtype == np.uint8
    assert v.cam_T_pipe is not None and v.pipe_left is not None and v.pipe_left.sum() > 5000
    uv = project_points(v.cam_T_pipe[:3, 3][None], rig.left)[0]
    u, w = int(round(uv[0])), int(round(uv[1]))
    if 0 <= u < rig.left.width and 0 <= w < rig.left.height:
        assert v.pipe_left[max(w - 3, 0) : w + 4, max(u - 3, 0) : u + 4].any()
    assert v.ends_cam is not None and np.allclose(np.linalg.norm(v.ends_cam[1] - v.ends_cam[0]), 1.0)
    back = load_view(save_view(v, tmp_path))
    assert back.cam_T_pipe is not None and back.pipe_left is not None
    np.testing.assert_array_equal(back.left, v.left)
    np.testing.assert_allclose(back.cam_T_pipe, v.cam_T_pipe)
    assert back.ends_visible == v.ends_visible and np.array_equal(back.pipe_left, v.pipe_left)
    free = make_view(4, "nopipe", "clear", 1.5, "eval", rig)
    assert free.cam_T_pipe is None and free.pipe_left is None and free.params["pipe_px"] == [0, 0]
    other = make_view(3, "pipe", "clear", 1.2, "tune", rig)
    assert not np.array_equal(other.left, v.left)
    third = make_view(3, "pipe", "clear", 1.2, "tune2", rig)
    assert not np.array_equal(third.left, v.left) and not np.array_equal(third.left, other.left)


def _band_view(step_bgr: tuple[float, float, float], noise: float, gradient: float, arm: bool) -> View:
    """A 400 x 300 view: a flat grey floor (a brightness ``gradient`` in levels per px across
    the pipe), a horizontal pipe band 60 px wide whose colour differs by ``step_bgr``, Gaussian
    noise of ``noise`` levels; with ``arm``, a bright blob over part of the ring, masked."""
    rng = np.random.default_rng(7)
    h, w = 300, 400
    yy = np.arange(h, dtype=np.float64)[:, None].repeat(w, axis=1)
    img = np.dstack([100.0 + gradient * (yy - h / 2)] * 3)
    pipe = (yy >= 120) & (yy < 180)
    img[pipe] += np.array(step_bgr)
    masks = None
    if arm:
        blob = np.zeros((h, w), np.uint8)
        blob[90:118, 50:200] = 255  # over the ring above the pipe
        img[blob > 0] = (250.0, 30.0, 30.0)
        masks = (blob, np.zeros_like(blob))
    img += rng.normal(0.0, noise, img.shape)
    im8 = np.clip(np.round(img), 0, 255).astype(np.uint8)
    return View("synthetic", "pipe", "clear", 1.0, im8, im8.copy(), np.eye(4), None, (), np.zeros(3), masks, {}, pipe)


def test_the_pipe_contrast_is_its_colour_step_against_the_floor_beside_it() -> None:
    """A known colour step comes back (its length, and its length without its grey part) within
    the noise of the means; a gradient across the pipe cancels; arm pixels do not count; the
    noise is the pixels' own."""
    c = pipe_contrast(_band_view((1.0, 3.0, 5.0), noise=2.0, gradient=0.0, arm=False))
    assert c is not None
    assert abs(c.colour - float(np.linalg.norm([1.0, 3.0, 5.0]))) < 0.15
    assert abs(c.chroma - float(np.linalg.norm([-2.0, 0.0, 2.0]))) < 0.15
    assert 1.6 < c.noise < 2.2  # 2 levels less what the 5 x 5 mean takes out with it
    tilted = pipe_contrast(_band_view((1.0, 3.0, 5.0), noise=2.0, gradient=0.2, arm=False))
    assert tilted is not None and abs(tilted.colour - c.colour) < 0.2  # 12 levels across the pipe cancel
    with_arm = pipe_contrast(_band_view((1.0, 3.0, 5.0), noise=2.0, gradient=0.0, arm=True))
    assert with_arm is not None and abs(with_arm.colour - c.colour) < 0.2
    grey = pipe_contrast(_band_view((-4.0, -4.0, -4.0), noise=1.0, gradient=0.0, arm=False))
    assert grey is not None and grey.colour > 6.5 and grey.chroma < 0.2  # darker, no colour


def test_a_view_without_a_pipe_or_too_little_of_it_has_no_contrast() -> None:
    v = _band_view((1.0, 3.0, 5.0), noise=1.0, gradient=0.0, arm=False)
    v.pipe_left = None
    assert pipe_contrast(v) is None
    v.pipe_left = np.zeros(v.left.shape[:2], bool)
    v.pipe_left[10:14, 10:14] = True  # 16 px: no core left 5 px inside it
    assert pipe_contrast(v) is None
