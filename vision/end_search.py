"""A pipe end searched along the fitted axis by integrating the score's fall along its rim.

In very turbid water the end outline's falls are as faint as the edges' and
sit in block noise of about their size: the profiles along the axis of
:func:`vision.silhouette._end_profiles` each find the largest noise peak, and
no set of them fits a rim. With the axis known (from the straight edges of
both cameras), the end has one unknown left, its axis coordinate ``s``. For
each candidate ``s`` the rim circle of the end cap is projected into every
camera that has a pipe score; on the part of its image that is the pipe's
outline (:func:`vision.cylinder._outline_arc`, for a cap whose face looks like
the pipe and for one whose face does not) the score is sampled a few pixels
inside and outside along the outline's normal. The mean fall over the arc and
over the cameras is a matched filter along the rim: the noise averages out
over a few hundred samples, the end's fall does not. The best ``s`` must stand
out from the others (a robust z-score over the searched span), its fall must be
a fair share of the pipe's contrast, and it must be a step at a wider scale too
(the score over the rims a few centimetres inside less that over those as far
beyond: noise and shading edges on a pipe that runs on fall and rise again,
an end does not); then the outline is measured at that
rim, point by point (the score's half level on profiles along the normal,
averaged over neighbouring points of the arc), and those points go to the
usual end fit (:func:`vision.cylinder.fit_end`), which judges them as any other
outline.
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

from vision.calibration import CameraModel, project_points, undistort_points
from vision.cylinder import AxisFit, _outline_arc, _rim_basis
from vision.silhouette import Score


@dataclass(frozen=True)
class RimSearch:
    """Settings of the end search along the rim (:func:`search_end`)."""

    enabled: bool = True
    #: the span searched (m): this far inside the colour region's extreme along the axis ...
    inside_m: float = 0.12
    #: ... and this far beyond it
    beyond_m: float = 0.25
    #: candidate ends this far apart along the axis (m)
    step_m: float = 0.003
    #: the best candidate's mean fall across the rim's outline, as a share of the pipe's contrast
    min_share: float = 0.2
    #: and that fall against the mean falls of the other candidates (a robust z-score over the
    #: span: the median and the median absolute deviation of those more than 3 steps away)
    min_z: float = 2.0
    #: the step at a wider scale: the score's mean level over the rims ``wide_m`` inside the end
    #: less that over the rims as far beyond it, at least this share of the fall across the rim
    #: (an end is a step; noise, or a shading edge on a pipe that runs on, falls and rises again)
    min_wide_share: float = 0.5
    #: the wider scale's reach (m) along the axis on each side, from 1 cm
    wide_m: float = 0.04
    #: a camera joins when this share of its rim's outline samples is usable (in the score's
    #: crop, away from the border and the arm); an end whose outline is cut more is hidden there
    min_usable: float = 0.7


@dataclass(frozen=True)
class RimView:
    """One camera for the search: its model and pose (``X_cam = R X_left + t``), its pipe
    score (raw pixels) and the arm's 'blocked' mask (None without an arm)."""

    index: int
    cam: CameraModel
    R: np.ndarray
    t: np.ndarray
    score: Score
    blocked: np.ndarray | None


@dataclass
class RimEnd:
    """An end found along the rim: its axis coordinate (m), its mean fall across the outline
    arc and the step at the wider scale (shares of the pipe's contrast), the robust z-score of
    the fall over the span searched, and the measured outline points (normalized,
    undistorted) per camera index."""

    s: float
    fall: float
    wide: float
    z: float
    outlines: dict[int, np.ndarray]


#: sample offsets (px) along the outline's outward normal: inside (negative) and outside
_OFFSETS = np.array([-4.5, -3.0, -1.5, 1.5, 3.0, 4.5], np.float32)
#: every other of the 96 rim points (3.75 degrees apart)
_RIM_STEP = 2


def _projected(
    fit: AxisFit, s: np.ndarray, basis: np.ndarray, view: RimView, outward: float
) -> tuple[np.ndarray, np.ndarray] | None:
    """Raw pixels (S, M, 2) of the rims at axis coordinates ``s`` in ``view`` and the unit
    outward normals (S, M, 2) of their images; None when a rim is (nearly) behind the camera."""
    centres = fit.p[None, :] + s[:, None] * fit.a[None, :]
    rims = centres[:, None, :] + basis[None]
    Xj = rims @ view.R.T + view.t
    if np.any(Xj[..., 2] <= 0.05):
        return None
    S, M = rims.shape[:2]
    px = project_points(Xj.reshape(-1, 3), view.cam).reshape(S, M, 2)
    # a point inside the pipe's silhouette: on the axis two radii into the body
    inner = (fit.p[None, :] + (s - outward * 2.0 * fit.r)[:, None] * fit.a[None, :]) @ view.R.T + view.t
    c_in = project_points(inner, view.cam)
    tangent = np.roll(px, -1, axis=1) - np.roll(px, 1, axis=1)
    nrm = np.stack([tangent[..., 1], -tangent[..., 0]], axis=-1)
    nrm /= np.maximum(np.linalg.norm(nrm, axis=-1, keepdims=True), 1e-9)
    flip = ((px - c_in[:, None, :]) * nrm).sum(axis=-1) < 0.0  # the silhouette is convex: outward is away from inside
    nrm[flip] *= -1.0
    return px, nrm


def _samples(view: RimView, px: np.ndarray, nrm: np.ndarray, offsets: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The score (..., k) at ``px + offsets * nrm`` (NaN outside its crop) and whether each
    point ``px`` is usable (inside the image by 3 px, off the arm)."""
    sc = view.score
    X = (px[..., None, 0] + offsets * nrm[..., None, 0]).astype(np.float32)
    Y = (px[..., None, 1] + offsets * nrm[..., None, 1]).astype(np.float32)
    shape = X.shape
    vals = cv2.remap(
        sc.image,
        (X - sc.x0).reshape(-1, shape[-1]),
        (Y - sc.y0).reshape(-1, shape[-1]),
        cv2.INTER_LINEAR,
        borderMode=cv2.BORDER_CONSTANT,
        borderValue=float("nan"),
    ).reshape(shape)
    W, H = view.cam.size
    x, y = px[..., 0], px[..., 1]
    ok = (x > 3.0) & (y > 3.0) & (x < W - 4.0) & (y < H - 4.0)
    if view.blocked is not None:
        xi = np.clip(np.round(x).astype(int), 0, W - 1)
        yi = np.clip(np.round(y).astype(int), 0, H - 1)
        ok &= view.blocked[yi, xi] == 0
    return vals, ok


def search_end(
    fit: AxisFit, views: list[RimView], s_from: float, outward: float, cfg: RimSearch = RimSearch()
) -> RimEnd | None:
    """The pipe end on the ``outward`` side (+1 or -1 along ``fit.a``) of axis coordinate
    ``s_from`` (the colour regions' extreme), searched from ``cfg.inside_m`` inside it to
    ``cfg.beyond_m`` beyond; None when no candidate's fall along the rim stands out."""
    if not views:
        return None
    s = s_from + outward * np.arange(-cfg.inside_m, cfg.beyond_m + 1e-9, cfg.step_m)
    basis = _rim_basis(fit)[::_RIM_STEP]
    centres = fit.p[None, :] + s[:, None] * fit.a[None, :]
    # each camera's rims projected and sampled once: the fall across the outline at every rim point
    sampled = []
    for v in views:
        proj = _projected(fit, s, basis, v, outward)
        if proj is None:
            continue
        px, nrm = proj
        vals, ok = _samples(v, px, nrm, _OFFSETS)
        k = len(_OFFSETS) // 2
        fall = (vals[..., :k].mean(axis=-1) - vals[..., k:].mean(axis=-1)) / max(v.score.contrast, 1e-6)
        sampled.append((v, fall, ok & np.isfinite(fall)))
    best: tuple[float, float, bool] | None = None  # the fall, its z-score and the face at the best s
    best_s = 0.0
    for face in (True, False):
        total = np.zeros(len(s))
        count = np.zeros(len(s))
        for v, fall, fine in sampled:
            arc = _outline_arc(fit, centres, basis, v.R, v.t, outward, face)
            good = arc & fine
            n = good.sum(axis=1)
            usable = n >= cfg.min_usable * np.maximum(arc.sum(axis=1), 1)
            total += np.where(usable, np.where(good, fall, 0.0).sum(axis=1) / np.maximum(n, 1), 0.0)
            count += usable
        if not count.any():
            continue
        F = np.where(count > 0, total / np.maximum(count, 1), np.nan)
        j = int(np.nanargmax(F))
        rest = F[(np.abs(np.arange(len(s)) - j) > 3) & np.isfinite(F)]
        med = float(np.median(rest)) if len(rest) else 0.0
        spread = 1.4826 * float(np.median(np.abs(rest - med))) + 1e-6 if len(rest) else 1e-6
        z = (float(F[j]) - med) / spread
        if best is None or float(F[j]) > best[0]:
            best, best_s = (float(F[j]), z, face), float(s[j])
    if best is None:
        return None
    share, z, face = best
    if share < cfg.min_share or z < cfg.min_z:
        return None
    wide = _wide_step(fit, views, basis, best_s, outward, face, cfg.wide_m)
    if not np.isfinite(wide) or wide < cfg.min_wide_share * share:
        return None
    outlines: dict[int, np.ndarray] = {}
    fine = np.linspace(-4.0, 4.0, 17, dtype=np.float32)
    for v in views:
        proj = _projected(fit, np.array([best_s]), basis, v, outward)
        if proj is None:
            continue
        px, nrm = proj
        arc = _outline_arc(fit, (fit.p + best_s * fit.a)[None, :], basis, v.R, v.t, outward, face)[0]
        vals, ok = _samples(v, px[0], nrm[0], fine)
        good = arc & ok
        if good.sum() < cfg.min_usable * max(arc.sum(), 1):
            continue  # the end's outline is cut by the border or the arm in this camera
        # profiles averaged over five neighbouring rim points: the noise is independent, the edge is not
        prof = cv2.blur(np.nan_to_num(vals).astype(np.float32), (1, 5), borderType=cv2.BORDER_WRAP)
        q = _half_level(prof)
        sel = good & np.isfinite(q)
        if sel.sum() < 6:
            continue
        pts = px[0][sel] + q[sel, None] * nrm[0][sel]
        outlines[v.index] = undistort_points(pts, v.cam)
    if not outlines:
        return None
    return RimEnd(best_s, share, wide, z, outlines)


def _wide_step(
    fit: AxisFit, views: list[RimView], basis: np.ndarray, s_end: float, outward: float, face: bool, reach: float
) -> float:
    """The mean score (shares of the pipe's contrast) on the outline arcs of the rims 1 cm to
    ``reach`` inside the end at ``s_end`` less that on those as far beyond it, averaged over the
    cameras where both are mostly usable; NaN where none is."""
    offsets = np.linspace(0.01, reach, 7)
    steps = []
    for v in views:
        levels = []
        for s in (s_end - outward * offsets, s_end + outward * offsets):
            proj = _projected(fit, s, basis, v, outward)
            if proj is None:
                break
            px, nrm = proj
            centres = fit.p[None, :] + s[:, None] * fit.a[None, :]
            arc = _outline_arc(fit, centres, basis, v.R, v.t, outward, face)
            vals, ok = _samples(v, px, nrm, np.zeros(1, np.float32))
            good = arc & ok & np.isfinite(vals[..., 0])
            if good.sum() < 0.5 * max(arc.sum(), 1):
                break
            levels.append(float(vals[..., 0][good].mean()) / max(v.score.contrast, 1e-6))
        if len(levels) == 2:
            steps.append(levels[0] - levels[1])
    return float(np.mean(steps)) if steps else float("nan")


def _half_level(prof: np.ndarray) -> np.ndarray:
    """Per profile (rows, 0.5 px samples from 4 px inside to 4 px outside), the offset (px)
    where the score crosses halfway between its levels at the two ends (the three outer
    samples each side), the crossing nearest the middle; NaN where it does not cross."""
    n, m = prof.shape
    inner = prof[:, :3].mean(axis=1)
    outer = prof[:, -3:].mean(axis=1)
    level = 0.5 * (inner + outer)
    a = prof[:, :-1] - level[:, None]
    b = prof[:, 1:] - level[:, None]
    cross = (a > 0) & (b <= 0) & (inner > outer)[:, None]
    with np.errstate(invalid="ignore", divide="ignore"):
        frac = a / (a - b)
    pos = -4.0 + 0.5 * (np.arange(m - 1)[None, :] + frac)
    dist = np.where(cross, np.abs(pos), np.inf)
    j = np.argmin(dist, axis=1)
    rows = np.arange(n)
    return np.where(np.isfinite(dist[rows, j]), pos[rows, j], np.nan)
