"""Cylinder geometry from image lines: tangent planes, the axis, the pipe end.

All 3D quantities are in the left camera frame (OpenCV optical frame, m).
A camera ``j`` sees a left-frame point ``X`` at ``X_j = R_j @ X + t_j``
(left camera: ``R = I, t = 0``; right camera: the calibration's ``R, T``).

A straight silhouette edge (limb) of a cylinder, seen by a camera, is a line
``a*x + b*y + c = 0`` in that camera's normalized image coordinates
(``x = X/Z``, ``y = Y/Z``); it spans a plane through the camera centre that
touches the cylinder along one generator. Every such tangent plane contains
the axis direction and lies at the radius from the axis, so from the planes
of the two cameras (four, two per camera):

* the axis direction ``a`` is the direction orthogonal to all plane normals
  (smallest singular vector of the stacked normals);
* a point ``p`` of the axis and the radius ``r`` solve ``n_i . p - d_i = r``
  (normals oriented towards the pipe), in least squares, with the known pipe
  radius as a weighted prior row. One camera alone fixes the axis only with
  that prior (depth from the apparent width), two cameras without it.

The pipe end is found along the fitted axis: the silhouette's end outline is
part of the projected rim circle of the end cap, so the end position ``s``
along the axis is the one whose projected rim best fits the observed end
outline points (a one-dimensional robust fit).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class Plane:
    """``n . X = d`` (left camera frame, unit normal ``n`` towards the pipe), with a weight."""

    n: np.ndarray
    d: float
    weight: float = 1.0
    camera: int = 0


@dataclass(frozen=True)
class AxisFit:
    """Cylinder fitted to tangent planes: axis point ``p`` (closest to the left
    camera centre), unit direction ``a``, radius ``r`` (m); ``plane_rms``: rms
    of the plane equations (m); ``direction_residual``: largest |n . a|;
    ``conditioning``: ratio of the two largest singular values of the normals
    (small = the planes barely constrain the direction)."""

    p: np.ndarray
    a: np.ndarray
    r: float
    plane_rms: float
    direction_residual: float
    conditioning: float
    n_cameras: int


def plane_from_line(
    line: np.ndarray, R: np.ndarray, t: np.ndarray, inside_ray: np.ndarray, camera: int, weight: float = 1.0
) -> Plane:
    """Tangent plane (left frame) spanned by a normalized image line ``(a, b, c)``
    of a camera at ``X_j = R X + t``; ``inside_ray`` (3,) (camera j frame) is a
    ray towards the inside of the silhouette, used to orient the normal."""
    n_j = np.asarray(line, dtype=float)
    n_j = n_j / np.linalg.norm(n_j)
    if n_j @ inside_ray < 0.0:
        n_j = -n_j
    # n_j . (R X + t) = 0  <=>  (R^T n_j) . X = -n_j . t
    return Plane(R.T @ n_j, float(-n_j @ t), weight, camera)


def fit_axis(planes: list[Plane], radius_prior: float | None = None, prior_weight: float = 1.0) -> AxisFit | None:
    """Least-squares cylinder axis and radius from >= 2 tangent planes (see module doc).

    Returns None when the planes cannot fix an axis (fewer than two, parallel
    normals, or one camera without a radius prior)."""
    if len(planes) < 2:
        return None
    N = np.array([p.n for p in planes])
    w = np.array([p.weight for p in planes])
    d = np.array([p.d for p in planes])
    if not (np.all(np.isfinite(N)) and np.all(np.isfinite(d)) and np.all(np.isfinite(w))):
        return None
    _, sv, vt = np.linalg.svd(N * w[:, None])
    a = vt[2]
    conditioning = float(sv[1] / sv[0]) if sv[0] > 0 else 0.0
    if conditioning < 1e-3:
        return None
    cams = {p.camera for p in planes}
    # unknowns [p (3), r]: rows n_i . p - r = d_i, a . p = 0, prior r = r0
    rows = [np.append(n, -1.0) * wi for n, wi in zip(N, w)]
    rhs = list(d * w)
    rows.append(np.append(a, 0.0))
    rhs.append(0.0)
    if radius_prior is not None and prior_weight > 0.0:
        rows.append(np.array([0.0, 0.0, 0.0, prior_weight]))
        rhs.append(prior_weight * radius_prior)
    elif len(cams) < 2:
        return None
    A, b = np.array(rows), np.array(rhs)
    sol, *_ = np.linalg.lstsq(A, b, rcond=None)
    if np.linalg.matrix_rank(A, tol=1e-9) < 4:
        return None
    p, r = sol[:3], float(sol[3])
    res = N @ p - r - d
    return AxisFit(p, a, r, float(np.sqrt(np.mean(res**2))), float(np.abs(N @ a).max()), conditioning, len(cams))


def axis_from_one_camera(first: Plane, second: Plane, radius: float, centre: np.ndarray) -> AxisFit | None:
    """The cylinder axis from the two tangent planes of ONE camera (both through its
    centre ``centre``, left frame; normals towards the pipe) and the known radius.

    The planes meet in a line through the camera centre parallel to the axis
    (direction ``n1 x n2``); the axis lies on the plane bisecting them, on the
    pipe's side, at ``radius / sin(theta / 2)`` from that line, ``theta`` the angle
    between the planes (the wedge holding the pipe): ``n1 . b = sin(theta / 2)``
    for the bisector's unit direction ``b = (n1 + n2) / |n1 + n2|``. None when the
    planes are (nearly) parallel. The axis point returned is the one closest to
    the left camera centre (the origin), as :func:`fit_axis` gives it."""
    n1, n2 = first.n / np.linalg.norm(first.n), second.n / np.linalg.norm(second.n)
    d = np.cross(n1, n2)
    nd = float(np.linalg.norm(d))
    if nd < 1e-6:
        return None
    a = d / nd
    b = n1 + n2
    nb = float(np.linalg.norm(b))
    if nb < 1e-9:
        return None
    b /= nb
    sin_half = float(n1 @ b)
    if sin_half <= 1e-6:
        return None
    p = np.asarray(centre, float) + (radius / sin_half) * b
    p = p - (p @ a) * a
    res = np.array([n1 @ p - first.d - radius, n2 @ p - second.d - radius])
    return AxisFit(p, a, float(radius), float(np.sqrt(np.mean(res**2))), 0.0, nd, 1)


def project(X: np.ndarray, R: np.ndarray, t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Normalized image coordinates (k, 2) of left-frame points ``X`` (k, 3) in
    camera ``(R, t)``, and their depths (k,)."""
    Xj = X @ R.T + t
    z = Xj[:, 2]
    return Xj[:, :2] / np.where(np.abs(z) < 1e-9, 1e-9, z)[:, None], z


def closest_point_on_axis(fit: AxisFit, ray_origin: np.ndarray, ray_dir: np.ndarray) -> float:
    """Axis coordinate ``s`` (m, from ``fit.p`` along ``fit.a``) of the axis point
    closest to a ray (left frame)."""
    u = ray_dir / np.linalg.norm(ray_dir)
    w0 = fit.p - ray_origin
    b = float(fit.a @ u)
    den = 1.0 - b * b
    if den < 1e-9:
        return 0.0
    return float((b * (u @ w0) - fit.a @ w0) / den)


_THETA = np.linspace(0.0, 2.0 * np.pi, 96, endpoint=False)
_COS, _SIN = np.cos(_THETA)[:, None], np.sin(_THETA)[:, None]


def _rim_basis(fit: AxisFit) -> np.ndarray:
    """Offsets (96, 3) from an end-cap centre to its rim (radius ``fit.r``)."""
    a = fit.a
    u = _cross(a, np.array([1.0, 0.0, 0.0]) if abs(a[0]) < 0.9 else np.array([0.0, 1.0, 0.0]))
    u /= np.sqrt(u @ u)
    v = _cross(a, u)
    return fit.r * (_COS * u + _SIN * v)


def _cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return np.array([a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]])


def rim_points(fit: AxisFit, s: float) -> np.ndarray:
    """Points (96, 3) on the rim circle of an end cap at axis coordinate ``s``."""
    return fit.p + s * fit.a + _rim_basis(fit)


def end_fit_costs(
    fit: AxisFit,
    s_values: np.ndarray,
    cams: list[tuple[np.ndarray, np.ndarray, np.ndarray, float]],
    huber_px: float = 1.0,
) -> np.ndarray:
    """Robust costs (px^2) of end caps at each axis coordinate of ``s_values``: for
    each camera ``(R, t, outline_points (k, 2) normalized, focal px)``, the Huber
    loss of every outline point's distance to the image of the rim circle.

    The rim (centre ``E``, normal ``a``, radius ``r``; camera frame) images to
    the conic ``x^T M x = 0`` with ``M = (a.E)^2 I - (a.E)(a E^T + E a^T) +
    (|E|^2 - r^2) a a^T`` (rays meeting the cap plane at distance ``r`` from
    ``E``); a point's distance to it is taken to first order (Sampson:
    ``x^T M x / |grad|``)."""
    s_values = np.atleast_1d(np.asarray(s_values, dtype=float))
    total = np.zeros(len(s_values))
    r2 = fit.r * fit.r
    eye = np.eye(3)
    for R, t, pts, f in cams:
        a = R @ fit.a
        E = (fit.p + s_values[:, None] * fit.a) @ R.T + t  # (S, 3) cap centres in camera j
        aE = E @ a  # (S,)
        M = (
            (aE**2)[:, None, None] * eye
            - aE[:, None, None] * (a[None, :, None] * E[:, None, :] + E[:, :, None] * a[None, None, :])
            + ((E * E).sum(axis=1) - r2)[:, None, None] * np.outer(a, a)[None]
        )
        x = np.column_stack([pts, np.ones(len(pts))])  # (k, 3)
        Mx = np.einsum("sij,kj->ski", M, x)  # (S, k, 3)
        val = np.einsum("ski,ki->sk", Mx, x)
        grad = 2.0 * np.sqrt(Mx[..., 0] ** 2 + Mx[..., 1] ** 2)
        dist = np.abs(val) / np.maximum(grad, 1e-12) * f
        bad = E[:, 2] <= fit.r  # the cap (partly) behind the camera
        cost = np.where(dist <= huber_px, 0.5 * dist * dist, huber_px * (dist - 0.5 * huber_px)).sum(axis=1)
        total += np.where(bad, np.inf, cost)
    return total


def _outline_arc(
    fit: AxisFit,
    E: np.ndarray,
    basis: np.ndarray,
    R: np.ndarray,
    t: np.ndarray,
    outward: float,
    face_like_pipe: bool = True,
) -> np.ndarray:
    """Which rim points (S, M) of end caps centred at ``E`` (S, 3) make the end's
    outline seen from camera ``(R, t)``, the end's outside being ``outward * fit.a``.

    The two limbs touch the rim where the viewing ray grazes the cylinder; they
    split the rim's image into two arcs. On a generator facing the camera, the
    visible side of the pipe ends at the rim; on one facing away, the rim borders
    the cap's face when the cap faces the camera, and is hidden otherwise. So the
    pipe-coloured part of the image ends at the rim points facing the camera when
    the cap faces away or when its face does not look like the pipe
    (``face_like_pipe`` False: a dark or open end), and at those facing away when
    the cap faces the camera and looks like the pipe. A few degrees more on each
    side keep the points next to the limbs."""
    C = -R.T @ t
    radial = basis / fit.r  # (M, 3) unit
    to_cam = C[None, :] - E  # (S, 3)
    facing = to_cam @ radial.T - fit.r  # (S, M) > 0: the generator faces the camera
    margin = 0.05 * np.linalg.norm(to_cam, axis=1)[:, None]  # about 3 degrees of the rim's angle
    front = facing > -margin
    if not face_like_pipe:
        return front
    cap_faces = outward * (to_cam @ fit.a) > 0.0  # (S,)
    return np.where(cap_faces[:, None], facing < margin, front)


def cap_faces_camera(fit: AxisFit, s: float, outward: float, R: np.ndarray, t: np.ndarray) -> bool:
    """Whether the end cap at ``s`` (outside ``outward * fit.a``) faces camera ``(R, t)``."""
    return bool(outward * float((-R.T @ t - fit.p - s * fit.a) @ fit.a) > 0.0)


def rim_fit_costs(
    fit: AxisFit,
    s_values: np.ndarray,
    cams: list[tuple[np.ndarray, np.ndarray, np.ndarray, float]],
    huber_px: float = 1.0,
    outward: float | None = None,
    face_like_pipe: bool = True,
) -> np.ndarray:
    """Like :func:`end_fit_costs` with exact distances: to the nearest of 96
    projected rim points (slower; used for the final refinement). With ``outward``
    (+1 or -1: the end's outside is ``outward * fit.a``), only to the rim points on
    the end's outline (:func:`_outline_arc`, for a cap's face like the pipe's side or
    not): otherwise the outline fits the far side of the rim's ellipse as well as
    the near one, with the end a cap's apparent width off."""
    s_values = np.atleast_1d(np.asarray(s_values, dtype=float))
    basis = _rim_basis(fit)
    if len(s_values) > 5:  # a coarse scan: every other rim point (3.75 deg apart) is plenty
        basis = basis[::2]
    centres = fit.p + s_values[:, None] * fit.a
    rims = centres[:, None, :] + basis[None]  # (S, 96 or 48, 3)
    total = np.zeros(len(s_values))
    for R, t, pts, f in cams:
        Xj = rims @ R.T + t
        z = Xj[..., 2]
        bad = np.any(z <= 0.0, axis=1)
        proj = Xj[..., :2] / np.where(z > 1e-9, z, 1e-9)[..., None]  # (S, M, 2)
        # squared distances |q - p|^2 = |q|^2 + |p|^2 - 2 q.p, one matrix product for all (S, M, k)
        d2 = (proj * proj).sum(axis=2)[:, :, None] - 2.0 * (proj @ pts.T)
        if outward is not None:
            arc = _outline_arc(fit, centres, basis, R, t, outward, face_like_pipe)
            d2 = np.where(arc[:, :, None], d2, np.inf)
        d2 = np.maximum(d2.min(axis=1) + (pts * pts).sum(axis=1)[None, :], 0.0) * (f * f)  # (S, k)
        dist = np.sqrt(d2)
        cost = np.where(dist <= huber_px, 0.5 * d2, huber_px * (dist - 0.5 * huber_px)).sum(axis=1)
        total += np.where(bad, np.inf, cost)
    return total


def rim_point_distances(
    fit: AxisFit,
    s: float,
    R: np.ndarray,
    t: np.ndarray,
    pts: np.ndarray,
    outward: float | None = None,
    face_like_pipe: bool = True,
) -> np.ndarray:
    """Distance (normalized units) of each outline point (k, 2) of camera ``(R, t)``
    to the projected rim polygon of the end cap at ``s`` (its outline arc only, with
    ``outward``: see :func:`rim_fit_costs`)."""
    basis = _rim_basis(fit)
    E = fit.p + s * fit.a
    X = (E + basis) @ R.T + t
    if np.any(X[:, 2] <= 0.0):
        return np.full(len(pts), np.inf)
    proj = X[:, :2] / X[:, 2:3]
    d2 = (proj * proj).sum(axis=1)[None, :] - 2.0 * (pts @ proj.T)  # less |p|^2, added after the minimum
    if outward is not None:
        arc = _outline_arc(fit, E[None, :], basis, R, t, outward, face_like_pipe)[0]
        d2 = np.where(arc[None, :], d2, np.inf)
    return np.sqrt(np.maximum(d2.min(axis=1) + (pts * pts).sum(axis=1), 0.0))


def end_fit_cost(
    fit: AxisFit,
    s: float,
    cams: list[tuple[np.ndarray, np.ndarray, np.ndarray, float]],
    huber_px: float = 1.0,
    outward: float | None = None,
    face_like_pipe: bool = True,
) -> float:
    """:func:`rim_fit_costs` for one ``s``."""
    return float(rim_fit_costs(fit, np.array([s]), cams, huber_px, outward, face_like_pipe)[0])


def fit_end(
    fit: AxisFit,
    s0: float,
    half_width: float,
    cams: list[tuple[np.ndarray, np.ndarray, np.ndarray, float]],
    tol: float = 5e-4,
    exact: bool = False,
    coarse: bool = True,
    outward: float | None = None,
    face_like_pipe: bool = True,
) -> tuple[float, float]:
    """Axis coordinate of an end cap near ``s0`` (searched in ``s0 +- half_width``, m)
    and the rms (px) of the outline points' exact distances to its rim (to the
    outline arc of the rim with ``outward``, the end's outside along the axis, and
    ``face_like_pipe``: see :func:`rim_fit_costs`).

    ``coarse``: first a scan with exact point-to-rim distances on a few points
    (the first-order cost has false minima far from the rim); then nested grids
    of :func:`end_fit_costs` (first-order distances; :func:`rim_fit_costs` with
    ``exact``) down to ``tol``, and a parabola through the best three."""
    if coarse:
        few = [(R, t, pts[:: max(1, len(pts) // 16)], f) for R, t, pts, f in cams]
        grid = np.linspace(s0 - half_width, s0 + half_width, 25)
        costs = rim_fit_costs(fit, grid, few, outward=outward, face_like_pipe=face_like_pipe)
        k = int(np.argmin(costs))
        step = grid[1] - grid[0]
        lo, hi = grid[k] - step, grid[k] + step
        if not np.isfinite(costs[k]):
            return float(grid[k]), float("inf")
    else:
        lo, hi = s0 - half_width, s0 + half_width
    while True:
        grid = np.linspace(lo, hi, 9)
        costs = (
            rim_fit_costs(fit, grid, cams, outward=outward, face_like_pipe=face_like_pipe)
            if exact
            else end_fit_costs(fit, grid, cams)
        )
        k = int(np.argmin(costs))
        step = grid[1] - grid[0]
        if step <= tol or not np.isfinite(costs[k]):
            break
        lo, hi = grid[k] - step, grid[k] + step
    s = float(grid[k])
    if 0 < k < len(grid) - 1 and np.all(np.isfinite(costs[k - 1 : k + 2])):
        c0, c1, c2 = costs[k - 1 : k + 2]
        den = c0 - 2.0 * c1 + c2
        if den > 0:
            s += 0.5 * step * (c0 - c2) / den
    sub = [(R, t, pts[:: max(1, len(pts) // 48)], f) for R, t, pts, f in cams]
    npts = sum(len(cam[2]) for cam in sub)
    cost = end_fit_cost(fit, s, sub, outward=outward, face_like_pipe=face_like_pipe)
    return s, float(np.sqrt(2.0 * cost / max(npts, 1)))


def grasp_rotation(axis: np.ndarray, gravity: np.ndarray | None, fallback_down: np.ndarray) -> tuple[np.ndarray, float]:
    """Rotation (3, 3) of a grasp frame: x along ``axis``, z along the part of
    ``gravity`` (unit, same frame) orthogonal to the axis, y = z x x. Returns it and
    the sine of the angle between axis and gravity (near 0: a vertical pipe, the
    roll about the axis is then taken from ``fallback_down``)."""
    x = axis / np.linalg.norm(axis)
    down = gravity if gravity is not None else fallback_down
    z = down - (down @ x) * x
    s = float(np.linalg.norm(z))
    if s < 0.2 and gravity is not None:
        z = fallback_down - (fallback_down @ x) * x
        s2 = float(np.linalg.norm(z))
        z = z / s2 if s2 > 1e-9 else np.cross(x, [1.0, 0.0, 0.0])
    else:
        z = z / s if s > 1e-9 else np.cross(x, [1.0, 0.0, 0.0])
    z /= np.linalg.norm(z)
    y = np.cross(z, x)
    return np.column_stack([x, y, z]), s
