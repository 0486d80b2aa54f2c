"""The independent evaluation set: its rig files, its truth, its splits."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from sim_backend.evalset import PLAN, SPLIT_SEEDS, eval_rig, load_view, make_view, plan, save_view, write_rig_files
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
