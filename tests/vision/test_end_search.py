"""The pipe end searched along the fitted axis, its fall integrated along the rim.

A capped pipe is ray-cast into two cameras 0.2 m apart; its pipe score is the
silhouette at a few levels of contrast, blurred, under block noise of about that
size (what the restoration leaves of a very turbid image). On profiles along
the axis, one by one, the largest fall is mostly noise; integrated along the
rim's image over both cameras, the end stands out and is found within a
centimetre. Where the pipe runs on through the whole span searched there is no
end, and none is reported (at that noise the best fall across a rim is as large
as a faint end's; the wider step is what tells them apart: beyond an end the
score falls at least halfway to the background's level, by more than that step's
noise along the pipe).
"""

from __future__ import annotations

import cv2
import numpy as np
import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st

from vision.calibration import CameraModel, project_points
from vision.cylinder import AxisFit
from vision.end_search import RimSearch, RimView, search_end
from vision.silhouette import Score

W, H, FOCAL = 640, 480, 700.0
RADIUS = 0.05
CONTRAST = 12.0
BASELINE = np.array([-0.2, 0.0, 0.0])  # X_right = X_left + t


def _camera() -> CameraModel:
    return CameraModel(W, H, np.array([[FOCAL, 0.0, W / 2], [0.0, FOCAL, H / 2], [0.0, 0.0, 1.0]]), np.zeros(5))


def _silhouette(p: np.ndarray, a: np.ndarray, s0: float, s1: float) -> np.ndarray:
    """Per pixel (camera at the origin, ``_camera``): whether its ray hits the capped pipe
    from ``s0`` to ``s1`` along ``a`` from ``p`` (its side or either cap's disc)."""
    v, u = np.mgrid[0:H, 0:W].astype(float)
    d = np.stack([(u - W / 2) / FOCAL, (v - H / 2) / FOCAL, np.ones_like(u)], axis=-1)
    d /= np.linalg.norm(d, axis=-1, keepdims=True)
    w = -p
    dp = d - (d @ a)[..., None] * a
    wp = w - (w @ a) * a
    A, B, C = np.sum(dp * dp, axis=-1), 2.0 * dp @ wp, wp @ wp - RADIUS**2
    disc = B * B - 4 * A * C
    with np.errstate(divide="ignore", invalid="ignore"):  # a ray along the axis (A = 0) meets no side
        t = np.where(disc >= 0, (-B - np.sqrt(np.maximum(disc, 0))) / (2 * A), np.inf)
    side = np.isfinite(t)
    s = (w @ a) + np.where(side, t, 0.0) * (d @ a)
    hit = side & (s >= s0) & (s <= s1)
    for s_cap in (s0, s1):
        E = p + s_cap * a
        with np.errstate(divide="ignore", invalid="ignore", over="ignore"):  # a ray parallel to the cap meets no disc
            tc = (E @ a) / (d @ a)
        tc = np.where(np.abs(tc) < 1e6, tc, -1.0)  # NaN and far beyond the scene: no hit
        hit |= (tc > 0) & (np.linalg.norm(tc[..., None] * d - E, axis=-1) <= RADIUS)
    return hit


def _score(mask: np.ndarray, rng: np.random.Generator, noise: float) -> Score:
    """The pipe score of a silhouette: ``CONTRAST`` on the pipe, 0 around it, blurred, with
    block noise (8 x 8 px blocks) and pixel noise."""
    img = np.asarray(cv2.GaussianBlur(mask.astype(np.float32) * CONTRAST, (0, 0), 1.2), np.float32)
    blocks = rng.normal(0.0, noise, (H // 8 + 1, W // 8 + 1)).astype(np.float32)
    img += np.repeat(np.repeat(blocks, 8, axis=0), 8, axis=1)[:H, :W]
    img += rng.normal(0.0, 0.5 * noise, (H, W)).astype(np.float32)
    return Score(cv2.GaussianBlur(img, (0, 0), 1.0), 0, 0, CONTRAST, 3, 0.6)


def _views(p: np.ndarray, a: np.ndarray, s0: float, s1: float, seed: int, noise: float) -> list[RimView]:
    rng = np.random.default_rng(seed)
    cam = _camera()
    out = []
    for k, t in enumerate((np.zeros(3), BASELINE)):
        mask = _silhouette(p + t, a, s0, s1)
        out.append(RimView(k, cam, np.eye(3), t, _score(mask, rng, noise), None))
    return out


def _pose(yaw: float, pitch: float) -> tuple[np.ndarray, np.ndarray]:
    a = np.array([np.cos(yaw) * np.cos(pitch), np.sin(pitch), np.sin(yaw) * np.cos(pitch)])
    return np.array([-0.1, 0.05, 1.0]), a / np.linalg.norm(a)


@settings(max_examples=8, deadline=None)
@given(st.floats(-0.5, 0.5), st.floats(-0.3, 0.3), st.floats(0.2, 0.4), st.integers(0, 2**16))
def test_a_faint_end_in_block_noise_is_found_along_the_rim(yaw: float, pitch: float, end: float, seed: int) -> None:
    p, a = _pose(yaw, pitch)
    views = _views(p, a, end - 1.0, end, seed, 0.45 * CONTRAST)
    fit = AxisFit(p, a, RADIUS, 0.0, 0.0, 1.0, 2)
    # one profile at a time: along the axis's image through the end, the largest fall is mostly noise
    left = views[0].score.image
    e_px = project_points((p + end * a)[None, :], views[0].cam)[0]
    b_px = project_points((p + (end - 0.1) * a)[None, :], views[0].cam)[0]
    u = (e_px - b_px) / np.linalg.norm(e_px - b_px)
    n = np.array([-u[1], u[0]])
    along = np.arange(-40.0, 40.0, 0.5)
    missed = 0
    lateral = np.linspace(-0.6, 0.6, 13) * FOCAL * RADIUS / 1.0
    for q in lateral:
        pts = e_px[None, :] + along[:, None] * u[None, :] + q * n[None, :]
        prof = cv2.remap(left, pts[:, 0:1].astype(np.float32), pts[:, 1:2].astype(np.float32), cv2.INTER_LINEAR)[:, 0]
        fall = prof[:-4] - prof[4:]
        missed += abs(float(along[int(np.argmax(fall)) + 2])) > 4.0
    # the scene tests the rim search only where one profile at a time cannot fit a rim
    assume(missed >= 4)
    # along the rim, from a colour region that stopped 6 cm short of the end
    found = search_end(fit, views, end - 0.06, 1.0, RimSearch())
    assert found is not None
    assert abs(found.s - end) < 0.01, (found.s, end)
    assert set(found.outlines) == {0, 1}


@settings(max_examples=6, deadline=None)
@given(st.floats(-0.5, 0.5), st.floats(-0.3, 0.3), st.integers(0, 2**16))
def test_no_end_is_reported_where_the_pipe_runs_on(yaw: float, pitch: float, seed: int) -> None:
    p, a = _pose(yaw, pitch)
    views = _views(p, a, -2.0, 2.0, seed, 0.45 * CONTRAST)  # both ends far outside the span searched
    fit = AxisFit(p, a, RADIUS, 0.0, 0.0, 1.0, 2)
    assert search_end(fit, views, 0.1, 1.0, RimSearch()) is None


def test_no_end_where_the_pipe_runs_on_in_noise_23088() -> None:
    """Noise with a fall and a partial wider step where the score beyond stays at the
    pipe's level: no end."""
    test_no_end_is_reported_where_the_pipe_runs_on.hypothesis.inner_test(0.0, 0.0, 23088)  # type: ignore[attr-defined]


@settings(max_examples=4, deadline=None)
@given(st.floats(-0.5, 0.4), st.floats(-0.3, 0.3), st.floats(0.2, 0.4), st.integers(0, 2**16))
def test_the_end_of_a_pipe_that_fades_towards_it_is_found(yaw: float, pitch: float, end: float, seed: int) -> None:
    """Near its end the pipe keeps under a fifth of the contrast the colour region measured
    (turbid water fading its far part): the fall across the rim is that small, but with
    little noise it stands out by far, and the end is found. (Yaw up to 0.4 rad: beyond,
    see the known miss below.)"""
    p, a = _pose(yaw, pitch)
    rng = np.random.default_rng(seed)
    views = []
    for k, t in enumerate((np.zeros(3), BASELINE)):
        faded = _score(_silhouette(p + t, a, end - 1.0, end), rng, 0.02 * CONTRAST)
        faded.image[...] *= 0.18  # the score under a fifth of the contrast the region measured
        views.append(RimView(k, _camera(), np.eye(3), t, faded, None))
    fit = AxisFit(p, a, RADIUS, 0.0, 0.0, 1.0, 2)
    found = search_end(fit, views, end - 0.06, 1.0, RimSearch())
    assert found is not None
    assert found.fall < RimSearch().min_share
    assert abs(found.s - end) < 0.01, (found.s, end)


@pytest.mark.xfail(strict=True, reason="known miss: docs/vision.md, Known limits (a faint end turned away)")
def test_the_faint_end_of_a_pipe_turned_away_from_the_camera() -> None:
    """The faded end of a pipe turned 29 deg away from the cameras, its end 1.2 m away: the
    fall along the rim is at the end, but spread over the neighbouring rims, its robust
    z-score over the span (4.4) stays under the 6 that a fall this faint needs
    (``RimSearch.strong_z``); no end is reported."""
    test_the_end_of_a_pipe_that_fades_towards_it_is_found.hypothesis.inner_test(0.5, 0.0, 0.375, 0)  # type: ignore[attr-defined]


@settings(max_examples=6, deadline=None)
@given(st.floats(-0.5, 0.5), st.floats(-0.3, 0.3), st.integers(0, 2**16))
def test_no_end_where_the_region_ran_past_the_pipe_onto_the_floor(yaw: float, pitch: float, seed: int) -> None:
    """The colour region ran 30 cm past the pipe's end onto the floor (a little less
    pipe-like than the mean background), and 10 cm further the floor turns darker still
    where a cylinder's rim would be: a fall across the rim and a wider step, but no pipe
    inside it. The true end lies outside the span searched from there; no end is reported."""
    p, a = _pose(yaw, pitch)
    end = 0.0
    rng = np.random.default_rng(seed)
    views = []
    for k, t in enumerate((np.zeros(3), BASELINE)):
        sc = _score(_silhouette(p + t, a, end - 1.0, end), rng, 0.2 * CONTRAST)
        near = _silhouette(p + t, a, end + 0.02, end + 0.4)  # the floor in the region, as a pipe's image
        far = _silhouette(p + t, a, end + 0.02, end + 2.0) & ~near  # beyond it, bounded by that end's rim
        beyond = cv2.GaussianBlur(far.astype(np.float32), (0, 0), 1.2)
        floor = near.astype(np.float32)
        sc.image[...] -= CONTRAST * (0.05 * floor + 0.6 * beyond)
        views.append(RimView(k, _camera(), np.eye(3), t, sc, None))
    fit = AxisFit(p, a, RADIUS, 0.0, 0.0, 1.0, 2)
    found = search_end(fit, views, end + 0.3, 1.0, RimSearch())
    assert found is None, (found.s, found.fall, found.inside)
    permissive = search_end(fit, views, end + 0.3, 1.0, RimSearch(min_inside_z=-np.inf))
    assert permissive is not None and abs(permissive.s - (end + 0.4)) < 0.01  # the fall the check refuses
