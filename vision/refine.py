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


def _limb_normals_rows(
    p: np.ndarray, a: np.ndarray, r: np.ndarray, C: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """:func:`_limb_normals` for rows of axis points (B, 3), unit directions (B, 3) and
    radii (B,): the two normals (B, 3) each, and which rows have the camera outside
    the cylinder (the others' normals are meaningless)."""
    w = p - C[None, :]
    w = w - np.sum(w * a, axis=1, keepdims=True) * a
    dist = np.linalg.norm(w, axis=1)
    seen = dist > r * 1.0001
    dist = np.where(seen, dist, 1.0)
    e = w / dist[:, None]
    f = np.column_stack(  # a x e per row (np.cross costs more than the arithmetic for a few rows)
        [
            a[:, 1] * e[:, 2] - a[:, 2] * e[:, 1],
            a[:, 2] * e[:, 0] - a[:, 0] * e[:, 2],
            a[:, 0] * e[:, 1] - a[:, 1] * e[:, 0],
        ]
    )
    sinb = np.where(seen, r / dist, 0.0)[:, None]
    cosb = np.sqrt(1.0 - sinb * sinb)
    return -(cosb * f - sinb * e), -(-cosb * f - sinb * e), seen


def rim_distance_rows(pts: np.ndarray, E: np.ndarray, a: np.ndarray, r: np.ndarray) -> np.ndarray:
    """:func:`rim_distance` of the points (k, 2) for rows of circles (centres E (B, 3),
    normals a (B, 3), radii (B,)): (B, k)."""
    aE = np.sum(a * E, axis=1)[:, None]
    c = (np.sum(E * E, axis=1) - r * r)[:, None]
    u, v = pts[None, :, 0], pts[None, :, 1]
    ex = u * E[:, 0:1] + v * E[:, 1:2] + E[:, 2:3]
    ax = u * a[:, 0:1] + v * a[:, 1:2] + a[:, 2:3]
    k1, k2 = -aE * ax, c * ax - aE * ex
    mx0 = aE * aE * u + k1 * E[:, 0:1] + k2 * a[:, 0:1]
    mx1 = aE * aE * v + k1 * E[:, 1:2] + k2 * a[:, 1:2]
    val = aE * aE * (u * u + v * v + 1.0) - 2.0 * aE * ex * ax + c * ax * ax
    return np.abs(val) / np.maximum(2.0 * np.sqrt(mx0 * mx0 + mx1 * mx1), 1e-15)


def huber_cost(r: np.ndarray, k: float = 1.0) -> float:
    a = np.abs(r)
    return float(np.where(a <= k, 0.5 * r * r, k * (a - 0.5 * k)).sum())


def levenberg_marquardt_huber(
    fun: Callable[[np.ndarray], np.ndarray],
    x0: np.ndarray,
    k: float = 1.0,
    max_iter: int = 8,
    step: float = 1e-6,
    xtol: float = 1e-6,
) -> np.ndarray | None:
    """Minimise the Huber loss (scale ``k``) of the residuals ``fun`` gives from ``x0``:
    Levenberg-Marquardt on iteratively reweighted least squares, forward-difference
    Jacobian. ``fun`` is batched: parameter rows (B, n) in, residual rows (B, m) out,
    so that the Jacobian's n perturbed points cost one call. It stops when a step
    gains less than 1e-5 of the cost or moves no parameter by ``xtol``. None if the
    start is not finite. (Small and self-contained: a handful of parameters, called ten times
    a second, where a general solver's overhead would dominate.)"""
    x = np.asarray(x0, dtype=float).copy()
    r = fun(x[None, :])[0]
    if not np.all(np.isfinite(r)):
        return None
    cost = huber_cost(r, k)
    lam = 1e-3
    n = len(x)
    for _ in range(max_iter):
        J = ((fun(x[None, :] + step * np.eye(n)) - r[None, :]) / step).T
        a = np.abs(r)
        w = np.where(a <= k, 1.0, k / np.maximum(a, 1e-12))
        JW = J * w[:, None]
        A = J.T @ JW
        g = JW.T @ r
        improved = False
        for _ in range(6):
            dx = np.linalg.solve(A + lam * np.diag(np.diag(A) + 1e-12), -g)
            xn = x + dx
            rn = fun(xn[None, :])[0]
            cn = huber_cost(rn, k) if np.all(np.isfinite(rn)) else np.inf
            if cn < cost:
                x, r, lam, improved = xn, rn, max(lam / 5.0, 1e-9), True
                gain, cost = cost - cn, cn
                break
            lam *= 8.0
        if not improved or gain < 1e-5 * max(cost, 1e-9) or np.abs(dx).max() < xtol:
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

    def unpack(X: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Axis points (B, 3), unit directions (B, 3) and radii (B,) of parameter rows (B, n)."""
        a = fit.a[None, :] + X[:, 0:1] * u0[None, :] + X[:, 1:2] * v0[None, :]
        a /= np.linalg.norm(a, axis=1, keepdims=True)
        return fit.p[None, :] + X[:, 2:3] * u0[None, :] + X[:, 3:4] * v0[None, :], a, fit.r * np.exp(X[:, 4])

    def residuals(X: np.ndarray) -> np.ndarray:
        """Residual rows (B, m) of parameter rows (B, n), px: the limb points, the end outline points, the priors."""
        p, a, r = unpack(X)
        out = []
        ok = np.ones(len(X), bool)
        for o, C, limb_pts, end_pts in views:
            n1, n2, seen = _limb_normals_rows(p, a, r, C)
            ok &= seen
            for nrm, pts in zip((n1, n2), limb_pts):
                if pts is not None:
                    ln = nrm @ o.R.T  # (B, 3) in camera j
                    out.append(np.abs(ln @ pts.T) * (o.focal / np.hypot(ln[:, 0], ln[:, 1]))[:, None])
            if end_pts:
                aj = a @ o.R.T
                for k, pts in end_pts.items():
                    E = (p + X[:, 5 + k : 6 + k] * a) @ o.R.T + o.t
                    front = E[:, 2] > r
                    d = rim_distance_rows(pts, np.where(front[:, None], E, 1.0), aj, r) * o.focal
                    out.append(np.where(front[:, None], d, 1e3))
        out.append((np.sqrt(prior_points) * (r - radius_prior) * focal / depth)[:, None])
        if use_length:
            out.append((np.sqrt(prior_points) * (np.abs(X[:, 6] - X[:, 5]) - length) / length_sigma)[:, None])
        res = np.concatenate(out, axis=1)
        res[~ok] = 1e3
        return res

    x0 = np.zeros(5 + len(ends))
    x0[5:] = ends
    try:
        x = levenberg_marquardt_huber(residuals, x0)
    except np.linalg.LinAlgError:
        return fit, ends, float("nan")
    if x is None or not np.all(np.isfinite(x)):
        return fit, ends, float("nan")
    P, A, Rr = unpack(x[None, :])
    p, a, r = P[0], A[0], float(Rr[0])
    res = residuals(x[None, :])[0][: -1 - int(use_length)]
    rms = float(np.sqrt(np.mean(np.minimum(np.abs(res), 5.0) ** 2))) if len(res) else float("nan")
    shift = -float(p @ a)  # keep the axis point the one closest to the left camera centre
    p = p + shift * a
    new_ends = [float(v) - shift for v in x[5:]]
    return (
        AxisFit(p, a, float(r), fit.plane_rms, fit.direction_residual, fit.conditioning, fit.n_cameras),
        new_ends,
        rms,
    )
