"""The pipe end from its outline: which arc of the rim's image the outline follows.

A capped pipe is ray-cast (exact intersections with the side and the cap's
disc, one ray per pixel); the outline of what looks like the pipe is the
boundary of the pixels that hit it (the side and, when the cap's face looks
like the pipe, the cap), away from the two straight edges. The end fitted to
that outline must be the true one, not the placement a cap's apparent width
away that fits the other half of the rim's ellipse as well.
"""

from __future__ import annotations

import cv2
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from vision.cylinder import AxisFit, cap_faces_camera, fit_end

FOCAL = 700.0
SIZE = 480
RADIUS = 0.05


def _hits(p: np.ndarray, a: np.ndarray, s_end: float, outward: float) -> tuple[np.ndarray, np.ndarray]:
    """Per pixel of a SIZE x SIZE camera at the origin (principal point at the centre):
    whether the ray hits the pipe's side, and whether it hits the cap's face first.
    The pipe runs from ``s_end - outward * 1.5`` to ``s_end`` along ``a`` from ``p``."""
    v, u = np.mgrid[0:SIZE, 0:SIZE].astype(float)
    d = np.stack([(u - SIZE / 2) / FOCAL, (v - SIZE / 2) / FOCAL, np.ones_like(u)], axis=-1)
    d /= np.linalg.norm(d, axis=-1, keepdims=True)
    w = -p  # ray origin (0) minus the axis point
    dp = d - (d @ a)[..., None] * a
    wp = w - (w @ a) * a
    A = np.sum(dp * dp, axis=-1)
    B = 2.0 * dp @ wp
    C = wp @ wp - RADIUS**2
    disc = B * B - 4 * A * C
    t_side = np.where(disc >= 0, (-B - np.sqrt(np.maximum(disc, 0))) / (2 * A), np.inf)
    with np.errstate(invalid="ignore"):
        s_side = (w @ a) + t_side * (d @ a)
    lo, hi = sorted((s_end - outward * 1.5, s_end))
    t_side = np.where((s_side >= lo) & (s_side <= hi) & (t_side > 0), t_side, np.inf)
    E = p + s_end * a
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):  # rays parallel to the cap
        t_cap = (E @ a) / (d @ a)
    t_cap = np.where(np.abs(t_cap) < 1e6, t_cap, -1.0)  # NaN and far beyond the scene: no hit
    X = t_cap[..., None] * d
    on_disc = np.linalg.norm(X - E, axis=-1) <= RADIUS
    t_cap = np.where(on_disc & (t_cap > 0), t_cap, np.inf)
    side = np.isfinite(t_side) & (t_side <= t_cap)
    cap = np.isfinite(t_cap) & (t_cap < t_side)
    return side, cap


def _outline(mask: np.ndarray, p: np.ndarray, a: np.ndarray, end: np.ndarray) -> np.ndarray:
    """Boundary points (normalized coordinates) of ``mask`` near the pipe end at ``end``
    (its image, within twice the cap's apparent size), more than 2 px from the pipe's
    two straight edges and from the image border."""
    cs, _ = cv2.findContours(mask.astype(np.uint8) * 255, cv2.RETR_EXTERNAL, cv2.CHAIN_APPROX_NONE)
    if not cs:
        return np.zeros((0, 2))
    pts = np.concatenate([c.reshape(-1, 2) for c in cs]).astype(float)
    inner = (pts > 3).all(axis=1) & (pts < SIZE - 4).all(axis=1)
    xy = (pts - SIZE / 2) / FOCAL
    inner &= np.linalg.norm(xy - end[:2] / end[2], axis=1) < 4.0 * RADIUS / end[2]
    w = p - (p @ a) * a  # the limbs: planes through the origin tangent to the cylinder
    dist = float(np.linalg.norm(w))
    e, f = w / dist, np.cross(a, w / dist)
    sb, cb = RADIUS / dist, np.sqrt(1 - (RADIUS / dist) ** 2)
    ray = np.column_stack([xy, np.ones(len(xy))])
    far = np.ones(len(xy), bool)
    for n in (cb * f - sb * e, -cb * f - sb * e):
        far &= np.abs(ray @ n) / np.hypot(n[0], n[1]) * FOCAL > 2.0
    return xy[inner & far]


@pytest.mark.slow  # seconds long: the full suite runs it, test-fast does not
@settings(max_examples=40, deadline=None)
@given(
    st.floats(0.8, 1.6),  # range
    st.floats(0.15, 0.9),  # the axis's angle towards or away from the camera (rad): the cap not edge-on
    st.booleans(),
    st.floats(0.0, np.pi),  # its direction in the image
    st.booleans(),  # the cap's face looks like the pipe
)
def test_the_end_follows_the_right_arc(rng: float, tilt: float, away: bool, roll: float, face_like_pipe: bool) -> None:
    towards = -tilt if away else tilt
    a = np.array([np.cos(roll) * np.cos(towards), np.sin(roll) * np.cos(towards), np.sin(towards)])
    s_end, outward = 0.12, 1.0  # the end a little off the image centre; the body towards -a
    p = np.array([0.0, 0.0, rng]) - s_end * a
    side, cap = _hits(p, a, s_end, outward)
    pts = _outline(side | cap if face_like_pipe else side, p, a, p + s_end * a)
    if len(pts) < 12:  # the end seen edge-on or hidden: nothing to fit
        return
    fit = AxisFit(p, a, RADIUS, 0.0, 0.0, 1.0, 1)
    cams = [(np.eye(3), np.zeros(3), pts, FOCAL)]
    faces = cap_faces_camera(fit, s_end, outward, np.eye(3), np.zeros(3))
    s, rms = fit_end(fit, s_end + 0.05, 0.17, cams, outward=outward, face_like_pipe=face_like_pipe or not faces)
    assert abs(s - s_end) < 0.004, (s, s_end, rms)  # 4 mm: the outline's pixel quantization, no cap width
    assert rms < 1.2
    if faces:  # the other reading of the outline fits it worse: the detector keeps the better one
        _, other = fit_end(fit, s_end + 0.05, 0.17, cams, outward=outward, face_like_pipe=not face_like_pipe)
        assert other > rms
