"""Joint refinement of the pipe: axis, radius and ends against all edge points.

The first estimate (:func:`vision.cylinder.fit_axis`, then the ends one by one)
uses the straight edges as planes and the ends along a fixed axis. When the
pipe lies nearly parallel to the baseline the two cameras' tangent planes
almost coincide and the depth rests on the apparent width; the end outlines,
seen with a disparity by the two cameras, then carry the missing information.
This step moves everything at once to minimise, in pixels, the distance of
every limb point to the image of the cylinder's limb in its camera and of
every end-outline point to the image of its end's rim, plus the known
radius as a prior (robust Huber loss, :func:`levenberg_marquardt_huber`).

Parameters: two angles tilting the axis direction, two offsets of the axis
point across it, the radius, and one axis coordinate per end.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from vision.cylinder import AxisFit


@dataclass
class Observations:
    """Edge points of one camera ``(R, t)`` (X_cam = R X_left + t), normalized
    coordinates: ``limbs`` [(k, 2), (k, 2)] (side order free), ``ends`` {index into
    the fitted ends: outline points (k, 2)}."""

    R: np.ndarray
    t: np.ndarray
    focal: float
    limbs: list
    ends: dict


def _cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return np.array([a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]])


def _basis(a: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    u = _cross(a, np.array([1.0, 0.0, 0.0]) if abs(a[0]) < 0.9 else np.array([0.0, 1.0, 0.0]))
    u /= np.sqrt(u @ u)
    return u, _cross(a, u)


def _limb_normals(p: np.ndarray, a: np.ndarray, r: float, C: np.ndarray) -> tuple[np.ndarray, np.ndarray] | None:
    """The two tangent planes' unit normals (left frame) from a camera centre ``C``."""
    w = p - C
    w = w - (w @ a) * a
    dist = float(np.sqrt(w @ w))
    if dist <= r * 1.0001:
        return None
    e = w / dist
    f = _cross(a, e)
    sinb = r / dist
    cosb = np.sqrt(1.0 - sinb * sinb)
    return -(cosb * f - sinb * e), -(-cosb * f - sinb * e)


def rim_distance(pts: np.ndarray, E: np.ndarray, a: np.ndarray, r: float) -> np.ndarray:
    """First-order (Sampson) distance, in normalized image units, of points (k, 2)
    to the image of a circle (centre ``E``, unit normal ``a``, radius ``r``;
    camera frame): the rays meeting the circle's plane at distance ``r`` from
    ``E`` form the cone ``x^T M x = 0``, ``M = (a.E)^2 I - (a.E)(a E^T + E a^T)
    + (|E|^2 - r^2) a a^T``; the distance is ``|x^T M x| / |d(x^T M x)/d(u, v)|``."""
    aE = float(a @ E)
    c = float(E @ E) - r * r
    u, v = pts[:, 0], pts[:, 1]
    ex = u * E[0] + v * E[1] + E[2]
    ax = u * a[0] + v * a[1] + a[2]
    k1, k2 = -aE * ax, c * ax - aE * ex  # M x = aE^2 x + k1 E + k2 a
    mx0 = aE * aE * u + k1 * E[0] + k2 * a[0]
    mx1 = aE * aE * v + k1 * E[1] + k2 * a[1]
    val = aE * aE * (u * u + v * v + 1.0) - 2.0 * aE * ex * ax + c * ax * ax
    return np.abs(val) / np.maximum(2.0 * np.sqrt(mx0 * mx0 + mx1 * mx1), 1e-15)


def huber_cost(r: np.ndarray, k: float = 1.0) -> float:
    a = np.abs(r)
    return float(np.where(a <= k, 0.5 * r * r, k * (a - 0.5 * k)).sum())


def levenberg_marquardt_huber(
    fun: Callable[[np.ndarray], np.ndarray], x0: np.ndarray, k: float = 1.0, max_iter: int = 8, step: float = 1e-6
) -> np.ndarray | None:
    """Minimise the Huber loss (scale ``k``) of ``fun(x)`` from ``x0``: Levenberg-Marquardt
    on iteratively reweighted least squares, forward-difference Jacobian. None if
    the start is not finite. (Small and self-contained: a handful of parameters,
    called ten times a second, where a general solver's overhead would dominate.)"""
    x = np.asarray(x0, dtype=float).copy()
    r = fun(x)
    if not np.all(np.isfinite(r)):
        return None
    cost = huber_cost(r, k)
    lam = 1e-3
    n = len(x)
    for _ in range(max_iter):
        J = np.empty((len(r), n))
        for j in range(n):
            xp = x.copy()
            xp[j] += step
            J[:, j] = (fun(xp) - r) / step
        a = np.abs(r)
        w = np.where(a <= k, 1.0, k / np.maximum(a, 1e-12))
        JW = J * w[:, None]
        A = J.T @ JW
        g = JW.T @ r
        improved = False
        for _ in range(6):
            dx = np.linalg.solve(A + lam * np.diag(np.diag(A) + 1e-12), -g)
            xn = x + dx
            rn = fun(xn)
            cn = huber_cost(rn, k) if np.all(np.isfinite(rn)) else np.inf
            if cn < cost:
                x, r, lam, improved = xn, rn, max(lam / 5.0, 1e-9), True
                gain, cost = cost - cn, cn
                break
            lam *= 8.0
        if not improved or gain < 1e-6 * max(cost, 1e-9) or np.abs(dx).max() < 1e-8:
            break
    return x


def refine(
    fit: AxisFit,
    ends: list[float],
    obs: list[Observations],
    radius_prior: float,
    prior_points: float = 10.0,
    max_points: int = 24,
    length_prior: float | None = None,
    length_sigma: float = 0.01,
) -> tuple[AxisFit, list[float], float]:
    """Refined ``(fit, end coordinates, rms px)`` (see module doc); returns the
    input unchanged (rms NaN) if the optimisation fails. With two ends and
    ``length_prior`` (m), their distance is held to it within ``length_sigma`` (m,
    one pixel's weight per sigma, ``prior_points`` times): when the pipe lies along
    the baseline the ends' positions fix its tilt, and the known length helps."""
    if not obs:
        return fit, list(ends), float("nan")
    u0, v0 = _basis(fit.a)
    ends = list(ends)
    depth = max(float(fit.p[2]), 0.1)
    focal = float(np.mean([o.focal for o in obs]))
    views: list[tuple[Observations, np.ndarray, list[np.ndarray | None], dict[int, np.ndarray]]] = []
    for o in obs:
        C = -o.R.T @ o.t
        normals = _limb_normals(fit.p, fit.a, fit.r, C)
        limb_pts: list[np.ndarray | None] = [None, None]  # points assigned to predicted limb 0 / 1
        for L in o.limbs:
            L = L[:: max(1, len(L) // max_points)]
            x3 = np.column_stack([L, np.ones(len(L))])
            if normals is None:
                continue
            d = [float(np.median(np.abs(x3 @ (o.R @ n)))) for n in normals]
            k = int(np.argmin(d))
            prev = limb_pts[k]
            limb_pts[k] = x3 if prev is None else np.concatenate([prev, x3])
        end_pts = {k: P[:: max(1, len(P) // max_points)] for k, P in o.ends.items() if 0 <= k < len(ends)}
        views.append((o, C, limb_pts, end_pts))
    length = float(length_prior) if length_prior is not None else 0.0
    use_length = length_prior is not None and len(ends) == 2
    n_res = (
        1
        + int(use_length)
        + sum(len(L) for _, _, lp, _ in views for L in lp if L is not None)
        + sum(len(P) for *_, ep in views for P in ep.values())
    )

    def unpack(x: np.ndarray) -> tuple[np.ndarray, np.ndarray, float]:
        a = fit.a + x[0] * u0 + x[1] * v0
        a /= np.sqrt(a @ a)
        return fit.p + x[2] * u0 + x[3] * v0, a, fit.r * float(np.exp(x[4]))

    def residuals(x: np.ndarray) -> np.ndarray:
        p, a, r = unpack(x)
        out = []
        for o, C, limb_pts, end_pts in views:
            normals = _limb_normals(p, a, r, C)
            if normals is None:
                return np.full(n_res, 1e3)
            for n, pts in zip(normals, limb_pts):
                if pts is not None:
                    ln = o.R @ n
                    out.append(np.abs(pts @ ln) * (o.focal / np.hypot(ln[0], ln[1])))
            if end_pts:
                aj = o.R @ a
                for k, pts in end_pts.items():
                    E = o.R @ (p + x[5 + k] * a) + o.t
                    if E[2] <= r:
                        out.append(np.full(len(pts), 1e3))
                        continue
                    out.append(rim_distance(pts, E, aj, r) * o.focal)
        out.append(np.array([np.sqrt(prior_points) * (r - radius_prior) * focal / depth]))
        if use_length:
            out.append(np.array([np.sqrt(prior_points) * (abs(x[6] - x[5]) - length) / length_sigma]))
        return np.concatenate(out)

    x0 = np.zeros(5 + len(ends))
    x0[5:] = ends
    try:
        x = levenberg_marquardt_huber(residuals, x0)
    except np.linalg.LinAlgError:
        return fit, ends, float("nan")
    if x is None or not np.all(np.isfinite(x)):
        return fit, ends, float("nan")
    p, a, r = unpack(x)
    res = residuals(x)[: -1 - int(use_length)]
    rms = float(np.sqrt(np.mean(np.minimum(np.abs(res), 5.0) ** 2))) if len(res) else float("nan")
    shift = -float(p @ a)  # keep the axis point the one closest to the left camera centre
    p = p + shift * a
    new_ends = [float(v) - shift for v in x[5:]]
    return (
        AxisFit(p, a, float(r), fit.plane_rms, fit.direction_residual, fit.conditioning, fit.n_cameras),
        new_ends,
        rms,
    )
