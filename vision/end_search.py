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
a fair share of the pipe's contrast (a smaller share, where the pipe fades towards
its end, only with much stronger evidence), and it must be a step at a wider scale too:
the score on the outline arcs of the rims a few centimetres inside less that on
those as far beyond must be at least half the level inside (beyond an end the
score is nearer the background's level than the pipe's; noise and shading edges
on a pipe that runs on fall and rise again) and stand out from the noise of
that same difference measured along the span away from the candidate (on the
pipe inside it and on whatever lies beyond). Then the outline is measured at that
rim, point by point (the score's half level on profiles along the normal,
averaged over neighbouring points of the arc), and those points go to the
usual end fit (:func:`vision.cylinder.fit_end`), which judges them as any other
outline.
"""

from __future__ import annotations

from dataclasses import dataclass, field

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
    #: a fainter fall (a pipe that fades towards its end in turbid water), down to this share,
    #: is taken when it and its wider step stand out by ``strong_z`` (both z-scores) ...
    min_faint_share: float = 0.1
    #: ... this many robust sigmas
    strong_z: float = 6.0
    #: the step at a wider scale: the score's mean level on the outline arcs of the rims 1 cm
    #: to ``wide_m`` inside the end less that on the rims as far beyond it, at least this share
    #: of the level inside and of the fall across the rim (beyond an end the score is nearer
    #: the background's level than the pipe's; noise, or a shading edge on a pipe that runs on,
    #: falls and rises again) ...
    min_wide_share: float = 0.5
    #: ... and at least this many times that step's noise where nothing ends (the same
    #: difference at the positions along the span away from the candidate)
    min_step_z: float = 3.0
    #: and the level inside the end above the background's (the score's 0) by at least this
    #: many times that noise: an end has the pipe inside it (a colour region that ran past the
    #: pipe's end onto the floor has a fall beyond it too, from the floor's level to a darker one)
    min_inside_z: float = 1.0
    #: the wider scale's reach (m) along the axis on each side, from 1 cm
    wide_m: float = 0.04
    #: the rims sampled reach this far (m) inside the span searched, so that the step's noise
    #: is measured on the pipe whatever the candidate
    body_m: float = 0.12
    #: a camera joins when this share of its rim's outline samples is usable (in the score's
    #: crop, away from the border and the arm); an end whose outline is cut more is hidden there
    min_usable: float = 0.7
    #: an end on an axis that both cameras' pairs of edges do not fix (``2+1``, ``1+2``) is
    #: taken only when every camera confirms it on its own (:meth:`RimEnd.unconfirmed`): at
    #: least this many cameras see its rim ...
    confirm_cameras: int = 2
    #: ... each with its own fall there standing out by this robust z-score over the span ...
    confirm_z: float = 2.0
    #: ... and its own best candidate within this distance (m) of the end
    confirm_offset_m: float = 0.01


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
    """An end found along the rim: its axis coordinate (m); its mean fall across the outline
    arc, the step at the wider scale and the level inside it (shares of the pipe's contrast);
    the robust z-score of the fall over the span searched; the step over its noise along the
    pipe; and the measured outline points (normalized, undistorted) per camera index."""

    s: float
    fall: float
    wide: float
    inside: float
    z: float
    step_z: float
    outlines: dict[int, np.ndarray]
    #: each searching camera's own evidence for this end (camera index -> :class:`CameraFall`)
    per_camera: dict[int, CameraFall] = field(default_factory=dict)
    #: the searching cameras whose image of the rim's outline at this end is cut by the image
    #: border or the arm (less than :attr:`RimSearch.min_usable` of it in view): they cannot see it
    hidden: tuple[int, ...] = ()

    def unconfirmed(self, cfg: RimSearch, cameras: tuple[int, ...] = (0, 1)) -> list[int]:
        """The cameras of ``cameras`` that do not confirm this end on their own: a camera
        whose rim at the end is unusable (cut by the border or the arm, out of the view),
        whose own fall there does not stand out by ``cfg.confirm_z`` or whose own best
        candidate lies more than ``cfg.confirm_offset_m`` away. A true end is one point seen
        by every camera; on a wrong axis each camera's image of the end falls at another
        place along it. Empty: confirmed (with fewer than ``cfg.confirm_cameras`` cameras
        never)."""
        bad = [
            j
            for j in cameras
            if not (
                j in self.per_camera
                and np.isfinite(self.per_camera[j].z)
                and self.per_camera[j].z >= cfg.confirm_z
                and self.per_camera[j].peak_offset_m <= cfg.confirm_offset_m
            )
        ]
        if not bad and len(cameras) < cfg.confirm_cameras:
            return list(cameras)
        return bad

    def contradicted_by(self, cfg: RimSearch, cameras: tuple[int, ...], blind: set[int]) -> list[int]:
        """The cameras of ``cameras`` (those not confirming the end, less the ``blind`` ones
        that cannot see it: their rim image there cut by the border or the arm) that place
        the end elsewhere: their own best candidate lies more than ``cfg.confirm_offset_m``
        from it, or their rim's image at the end is off the pipe's score altogether. A camera
        whose own best is at the end but stands out less than ``cfg.confirm_z`` sees the end
        there, faintly: on a right axis with a faint end that is the usual case, and it does
        not count against the axis."""
        out = []
        for j in cameras:
            if j in blind:
                continue
            own = self.per_camera.get(j)
            if own is None or not np.isfinite(own.fall) or own.peak_offset_m > cfg.confirm_offset_m:
                out.append(j)
        return out


@dataclass(frozen=True)
class CameraFall:
    """One camera's own fall across the rim's outline arc, the cameras' mean being what
    chose the end: its fall at the end (share of the pipe's contrast; NaN where its arc is
    unusable there), its robust z-score over the span (as :attr:`RimSearch.min_z`'s), and
    how far (m, along the axis) its own best candidate lies from the end."""

    fall: float
    z: float
    peak_offset_m: float


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
    # the rims sampled reach ``wide_m`` beyond the candidates, for the wider step, and
    # ``body_m`` inside them, for the noise of that step along the pipe
    pad = int(np.ceil(cfg.wide_m / cfg.step_m))
    body = int(np.ceil(cfg.body_m / cfg.step_m))
    k = np.arange(-int(round(cfg.inside_m / cfg.step_m)) - body, int(round(cfg.beyond_m / cfg.step_m)) + pad + 1)
    s = s_from + outward * k * cfg.step_m
    candidate = np.zeros(len(s), bool)
    candidate[body : len(s) - pad] = True
    basis = _rim_basis(fit)[::_RIM_STEP]
    centres = fit.p[None, :] + s[:, None] * fit.a[None, :]
    # each camera's rims projected and sampled once: the fall across the outline at every rim
    # point and the score on the outline itself
    sampled = []
    half = len(_OFFSETS) // 2
    offsets = np.append(_OFFSETS, np.float32(0.0))
    for v in views:
        proj = _projected(fit, s, basis, v, outward)
        if proj is None:
            continue
        px, nrm = proj
        vals, ok = _samples(v, px, nrm, offsets)
        c = max(v.score.contrast, 1e-6)
        fall = (vals[..., :half].mean(axis=-1) - vals[..., half:-1].mean(axis=-1)) / c
        level = vals[..., -1] / c
        sampled.append((v, fall, level, ok & np.isfinite(fall) & np.isfinite(level)))
    best: _Candidate | None = None
    best_own: dict[int, np.ndarray] = {}
    for face in (True, False):
        own = {}  # per camera: its mean fall across each rim's outline arc, NaN where unusable
        levels = []  # per camera: the mean score on each rim's outline arc, NaN where unusable
        for v, fall, level, fine in sampled:
            arc = _outline_arc(fit, centres, basis, v.R, v.t, outward, face)
            good = arc & fine
            n = good.sum(axis=1)
            usable = n >= cfg.min_usable * np.maximum(arc.sum(axis=1), 1)
            own[v.index] = np.where(usable, np.where(good, fall, 0.0).sum(axis=1) / np.maximum(n, 1), np.nan)
            levels.append(np.where(usable, np.where(good, level, 0.0).sum(axis=1) / np.maximum(n, 1), np.nan))
        if not own:
            continue
        stack = np.array(list(own.values()))
        count = np.isfinite(stack).sum(axis=0)
        if not count[candidate].any():
            continue
        fall_sum = np.nansum(stack, axis=0)
        F = np.where(candidate & (count > 0), fall_sum / np.maximum(count, 1), np.nan)
        j = int(np.nanargmax(F))
        z = _robust_z(F, j)
        if best is None or float(F[j]) > best.fall:
            best = _Candidate(float(s[j]), float(F[j]), z, face, *_step(np.array(levels), j, cfg))
            best_own = {k: np.where(candidate, f, np.nan) for k, f in own.items()}
    if best is None:
        return None
    if best.fall < cfg.min_faint_share or best.z < cfg.min_z:
        return None
    # the step at the wider scale: the score beyond the end nearer the background's level than
    # the pipe's as measured inside it, and more than that step's noise where nothing ends
    step = best.inside - best.beyond
    if not (np.isfinite(step) and np.isfinite(best.noise)):
        return None
    if step < cfg.min_wide_share * max(best.inside, best.fall) or step < cfg.min_step_z * best.noise:
        return None
    if best.inside < cfg.min_inside_z * best.noise:
        return None  # no pipe inside: a fall from the floor's level to a darker one
    if best.fall < cfg.min_share and min(best.z, step / max(best.noise, 1e-9)) < cfg.strong_z:
        return None  # a faint fall needs the stronger evidence
    best_s, face = best.s, best.face
    outlines: dict[int, np.ndarray] = {}
    hidden: list[int] = []
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
            hidden.append(v.index)
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
    j_best = int(np.argmin(np.abs(s - best_s)))
    per_camera: dict[int, CameraFall] = {}
    for index, f in best_own.items():
        if not np.isfinite(f).any():
            continue
        j_own = int(np.nanargmax(f))
        per_camera[index] = CameraFall(float(f[j_best]), _robust_z(f, j_best), float(abs(s[j_own] - best_s)))
    return RimEnd(
        best_s, best.fall, step, best.inside, best.z, step / max(best.noise, 1e-6), outlines, per_camera, tuple(hidden)
    )


def _robust_z(F: np.ndarray, j: int) -> float:
    """The robust z-score of ``F[j]`` against the finite values of ``F`` more than 3 entries
    away (their median and 1.4826 x their median absolute deviation); NaN where ``F[j]`` is."""
    if not np.isfinite(F[j]):
        return float("nan")
    rest = F[(np.abs(np.arange(len(F)) - j) > 3) & np.isfinite(F)]
    med = float(np.median(rest)) if len(rest) else 0.0
    spread = 1.4826 * float(np.median(np.abs(rest - med))) + 1e-6 if len(rest) else 1e-6
    return (float(F[j]) - med) / spread


@dataclass(frozen=True)
class _Candidate:
    """The best candidate end of one face hypothesis: its axis coordinate (m), mean fall and
    z-score, and the levels of :func:`_step`."""

    s: float
    fall: float
    z: float
    face: bool
    inside: float
    beyond: float
    noise: float


def _step(levels: np.ndarray, j: int, cfg: RimSearch) -> tuple[float, float, float]:
    """From the score on the rims' outline arcs (``levels`` (cameras, rims): shares of the
    pipe's contrast, NaN where unusable; rims ``cfg.step_m`` apart, ordered from inside to
    beyond) and the candidate end at rim ``j``: the mean level on the rims 1 cm to
    ``cfg.wide_m`` inside the end, that on the rims as far beyond, and the noise of that
    difference where nothing ends (1.4826 x the median of its magnitude over the positions
    whose two windows both stay 1 cm clear of rim ``j``: along the pipe inside the end and
    over whatever lies beyond it). Each camera's difference is taken on its own windows and
    the cameras' differences averaged, so that a camera leaving the view makes no step. NaN
    where undefined (the noise needs at least ``wide_m`` of such positions)."""
    near, far = int(np.ceil(0.01 / cfg.step_m)), int(round(cfg.wide_m / cfg.step_m))
    n_rims = levels.shape[1]
    if j - far < 0 or j + far >= n_rims:
        return float("nan"), float("nan"), float("nan")
    at = np.arange(far, n_rims - far)
    ins, outs = [], []
    for level in levels:
        valid = np.isfinite(level)
        total = np.concatenate([[0.0], np.cumsum(np.where(valid, level, 0.0))])
        count = np.concatenate([[0], np.cumsum(valid)])
        lo_in, hi_in, lo_out, hi_out = at - far, at - near, at + near, at + far
        n_in, n_out = count[hi_in + 1] - count[lo_in], count[hi_out + 1] - count[lo_out]
        enough = (n_in >= 0.5 * (far - near + 1)) & (n_out >= 0.5 * (far - near + 1))
        ins.append(np.where(enough, (total[hi_in + 1] - total[lo_in]) / np.maximum(n_in, 1), np.nan))
        outs.append(np.where(enough, (total[hi_out + 1] - total[lo_out]) / np.maximum(n_out, 1), np.nan))
    # the cameras' mean where any covers a position (the two windows are NaN together), else NaN
    covered = np.isfinite(ins).sum(axis=0)
    inside = np.where(covered > 0, np.nansum(ins, axis=0) / np.maximum(covered, 1), np.nan)
    beyond = np.where(covered > 0, np.nansum(outs, axis=0) / np.maximum(covered, 1), np.nan)
    step = inside - beyond
    k = j - far
    away = ((at + far <= j - near) | (at - far >= j + near)) & np.isfinite(step)
    if away.sum() < far:
        return float(inside[k]), float(beyond[k]), float("nan")
    return float(inside[k]), float(beyond[k]), 1.4826 * float(np.median(np.abs(step[away])))


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
