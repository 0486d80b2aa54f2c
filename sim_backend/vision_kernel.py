"""The geometry of one image of the table vision model, compiled (:mod:`sim_backend.vision`).

:func:`image_view` computes at each image (~10 Hz) what
:meth:`sim_backend.vision.VisionModel.probability` decides from: the grasp
point in the camera frame, its range, whether it is inside the field of view
and the usable range, and whether an arm link hides it (:func:`sim_backend.vision.occluded`:
5 points per link, a cylinder of ``occlusion_radius_m`` around the line of
sight). Same formulas as the numpy functions of :mod:`sim_backend.vision`, in
one call instead of some thirty numpy calls on 3-vectors; the sums are in
another order, so the range agrees with the numpy code to rounding (~1e-16
relative), not bit for bit (``tests/sim_backend/test_sim_vision.py`` compares
both on random views).

Parameters ``par`` (``V_*`` indices): full field-of-view angles (rad), the
usable range (m), the occlusion radius (m). Results ``out`` (``O_*``): range
(m), in view (1/0), occluded (1/0), the grasp point in the camera frame (3, m).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

V_FOV_H, V_FOV_V, V_MIN_RANGE, V_MAX_RANGE, V_OCC_RADIUS = range(5)
N_V = 5
O_RANGE, O_IN_VIEW, O_OCCLUDED, O_TARGET = 0, 1, 2, 3
N_O = 6

#: the occlusion test's margin (m): a link must be this much closer than the target (vision.points_block_ray)
OCC_MARGIN_M = 0.1
#: points per link along the segment (vision.sample_segments: linspace(0, 1, 5))
_SAMPLES = np.linspace(0.0, 1.0, 5)


@njit(cache=True)
def image_view(
    wTc: np.ndarray, wTg: np.ndarray, arm_w: np.ndarray, par: np.ndarray, samples: np.ndarray, out: np.ndarray
) -> None:
    """The view of the grasp frame ``wTg`` (4, 4, world) from the camera at ``wTc`` (4, 4,
    world) with the arm points ``arm_w`` (k, 3, world) into ``out`` (see the module docstring);
    ``samples``: the fractions along each link where the occlusion is tested."""
    # the grasp point in the camera frame: R^T (g - p), as inverse_pose then R.dot(g) + o
    tx = ty = tz = 0.0
    ox = oy = oz = 0.0
    for j in range(3):
        p = wTc[j, 3]
        g = wTg[j, 3]
        tx += wTc[j, 0] * g
        ty += wTc[j, 1] * g
        tz += wTc[j, 2] * g
        ox -= wTc[j, 0] * p
        oy -= wTc[j, 1] * p
        oz -= wTc[j, 2] * p
    tx += ox
    ty += oy
    tz += oz
    out[O_TARGET] = tx
    out[O_TARGET + 1] = ty
    out[O_TARGET + 2] = tz
    rng = math.sqrt(tx * tx + ty * ty + tz * tz)
    out[O_RANGE] = rng
    in_view = (
        tz > 0.0
        and abs(math.atan2(tx, tz)) <= 0.5 * par[V_FOV_H]
        and abs(math.atan2(ty, tz)) <= 0.5 * par[V_FOV_V]
        and par[V_MIN_RANGE] <= rng <= par[V_MAX_RANGE]
    )
    out[O_IN_VIEW] = 1.0 if in_view else 0.0
    occ = False
    k = arm_w.shape[0]
    if in_view and k >= 2 and rng > 0.0:
        dx, dy, dz = tx / rng, ty / rng, tz / rng
        r2 = par[V_OCC_RADIUS] * par[V_OCC_RADIUS]
        limit = rng - OCC_MARGIN_M
        for i in range(k - 1):
            # the link's end points in the camera frame: R^T x + o
            a0 = a1 = a2 = b0 = b1 = b2 = 0.0
            for j in range(3):
                xa = arm_w[i, j]
                xb = arm_w[i + 1, j]
                a0 += wTc[j, 0] * xa
                a1 += wTc[j, 1] * xa
                a2 += wTc[j, 2] * xa
                b0 += wTc[j, 0] * xb
                b1 += wTc[j, 1] * xb
                b2 += wTc[j, 2] * xb
            a0 += ox
            a1 += oy
            a2 += oz
            b0 += ox
            b1 += oy
            b2 += oz
            for s in samples:
                px = a0 + s * (b0 - a0)
                py = a1 + s * (b1 - a1)
                pz = a2 + s * (b2 - a2)
                along = px * dx + py * dy + pz * dz
                perp2 = (px * px + py * py + pz * pz) - along * along
                if along > 0.0 and along < limit and perp2 < r2:
                    occ = True
                    break
            if occ:
                break
    out[O_OCCLUDED] = 1.0 if occ else 0.0


# ---------------------------------------------------------------- detection pose

#: :func:`detection_pose`'s ``calib`` buffer: the matrices of
#: :meth:`sim_backend.vision_calibration.StereoBias.apparent` (each 3 x 3 row-major, or 3),
#: then the camera mount error (4 x 4 row-major), then the grasp-axis span (m) of
#: :meth:`~sim_backend.vision_calibration.StereoBias.apparent_pose`
C_KLT, C_RT, C_T, C_KRT, C_KLINVT, C_KRINVT_R, C_CR, C_MOUNT, C_SPAN = 0, 9, 18, 21, 30, 39, 48, 51, 67
N_C = 68


def calibration_buffer(mats: tuple[np.ndarray, ...] | None, mount: np.ndarray | None, span_m: float) -> np.ndarray:
    """The ``calib`` buffer of :func:`detection_pose` from ``StereoBias.triangulation_matrices`` and the
    mount error (None, None: an exact calibration; the buffer is then unused)."""
    buf = np.zeros(N_C)
    if mats is not None and mount is not None:
        klt, rt, t, krt, klinvt, krinvt_r, cr = mats
        buf[C_KLT:C_RT] = klt.ravel()
        buf[C_RT:C_T] = rt.ravel()
        buf[C_T:C_KRT] = t.ravel()
        buf[C_KRT:C_KLINVT] = krt.ravel()
        buf[C_KLINVT:C_KRINVT_R] = klinvt.ravel()
        buf[C_KRINVT_R:C_CR] = krinvt_r.ravel()
        buf[C_CR:C_MOUNT] = cr.ravel()
        buf[C_MOUNT:C_SPAN] = np.asarray(mount, dtype=float).ravel()
    buf[C_SPAN] = span_m
    return buf


@njit(cache=True)
def _row_times(p0: float, p1: float, p2: float, m: np.ndarray, o: int) -> tuple[float, float, float]:
    """The row vector ``[p0 p1 p2]`` times the 3 x 3 matrix stored row-major at ``m[o:o + 9]``."""
    return (
        p0 * m[o] + p1 * m[o + 3] + p2 * m[o + 6],
        p0 * m[o + 1] + p1 * m[o + 4] + p2 * m[o + 7],
        p0 * m[o + 2] + p1 * m[o + 5] + p2 * m[o + 8],
    )


@njit(cache=True)
def _apparent_point(p0: float, p1: float, p2: float, c: np.ndarray) -> tuple[float, float, float]:
    """:meth:`StereoBias.apparent` of one point (real left camera frame, m): projected by
    the real cameras, triangulated with the believed ones (midpoint of the two rays)."""
    ul, vl, wl = _row_times(p0, p1, p2, c, C_KLT)
    ul, vl, wl = ul / wl, vl / wl, 1.0
    r0, r1, r2 = _row_times(p0, p1, p2, c, C_RT)
    ur, vr, wr = _row_times(r0 + c[C_T], r1 + c[C_T + 1], r2 + c[C_T + 2], c, C_KRT)
    ur, vr, wr = ur / wr, vr / wr, 1.0
    d0, d1, d2 = _row_times(ul, vl, wl, c, C_KLINVT)
    e0, e1, e2 = _row_times(ur, vr, wr, c, C_KRINVT_R)
    cr0, cr1, cr2 = c[C_CR], c[C_CR + 1], c[C_CR + 2]
    a11 = d0 * d0 + d1 * d1 + d2 * d2
    a12 = -(d0 * e0 + d1 * e1 + d2 * e2)
    a22 = e0 * e0 + e1 * e1 + e2 * e2
    q1 = d0 * cr0 + d1 * cr1 + d2 * cr2
    q2 = -(e0 * cr0 + e1 * cr1 + e2 * cr2)
    det = a11 * a22 - a12 * a12
    if abs(det) < 1e-15:
        det = 1e-15
    s = (q1 * a22 - a12 * q2) / det
    u = (a11 * q2 - a12 * q1) / det
    return 0.5 * (s * d0 + (cr0 + u * e0)), 0.5 * (s * d1 + (cr1 + u * e1)), 0.5 * (s * d2 + (cr2 + u * e2))


@njit(cache=True)
def _mul4(A: np.ndarray, B: np.ndarray, out: np.ndarray) -> None:
    """``out = A B`` for 4 x 4 poses (out must not be A or B)."""
    for i in range(4):
        for j in range(4):
            acc = 0.0
            for k in range(4):
                acc += A[i, k] * B[k, j]
            out[i, j] = acc


@njit(cache=True)
def _inverse4(T: np.ndarray, out: np.ndarray) -> None:
    """Inverse of the homogeneous pose ``T`` into ``out``."""
    for i in range(3):
        for j in range(3):
            out[i, j] = T[j, i]
        out[i, 3] = -(T[0, i] * T[0, 3] + T[1, i] * T[1, 3] + T[2, i] * T[2, 3])
        out[3, i] = 0.0
    out[3, 3] = 1.0


@njit(cache=True)
def detection_pose(
    wTv: np.ndarray,
    wTc: np.ndarray,
    wTg: np.ndarray,
    calib: np.ndarray,
    with_errors: bool,
    n: np.ndarray,
    pos_noise: float,
    ang_noise: float,
    rng_m: float,
    work: np.ndarray,
    out: np.ndarray,
) -> None:
    """The detected grasp frame in the vehicle frame (4 x 4, into ``out``) of one image,
    as :meth:`sim_backend.vision.VisionModel.capture` builds it: the true ``vTg`` from the
    world poses of the vehicle, the camera and the grasp frame (``wTv``, ``wTc``,
    ``wTg``); with ``with_errors``, seen through the run's calibration errors
    (:meth:`~sim_backend.vision_calibration.VisionErrors.measured_vehicle_pose`, matrices
    in ``calib``, see :func:`calibration_buffer`); then the image's noise from the six
    standard normal draws ``n``: a rotation of the axis direction (``ang_noise`` rad, a
    tenth of it about the pipe axis) and a camera-frame position error growing with
    the range ``rng_m`` (``pos_noise`` x range across the line of sight, x range squared
    along it). ``work``: scratch (3, 4, 4)."""
    vTw, vTc, vTg = work[0], work[1], work[2]
    _inverse4(wTv, vTw)
    if not with_errors:
        _mul4(vTw, wTg, vTg)
    else:
        _mul4(vTw, wTc, vTc)
        cTw, cTg = out, work[2]
        _inverse4(wTc, cTw)
        _mul4(cTw, wTg, cTg)
        # the grasp frame as the believed calibration sees it (StereoBias.apparent_pose)
        span = calib[C_SPAN]
        o0, o1, o2 = cTg[0, 3], cTg[1, 3], cTg[2, 3]
        a0, a1, a2 = _apparent_point(o0, o1, o2, calib)
        b0, b1, b2 = _apparent_point(o0 + span * cTg[0, 0], o1 + span * cTg[1, 0], o2 + span * cTg[2, 0], calib)
        x0, x1, x2 = b0 - a0, b1 - a1, b2 - a2
        nx = math.sqrt(x0 * x0 + x1 * x1 + x2 * x2)
        x0, x1, x2 = x0 / nx, x1 / nx, x2 / nx
        z0, z1, z2 = cTg[0, 2], cTg[1, 2], cTg[2, 2]
        zx = z0 * x0 + z1 * x1 + z2 * x2
        w0, w1, w2 = z0 - zx * x0, z1 - zx * x1, z2 - zx * x2
        nz = math.sqrt(w0 * w0 + w1 * w1 + w2 * w2)
        if nz > 1e-9:
            z0, z1, z2 = w0 / nz, w1 / nz, w2 / nz
        cam = work[2]  # (cTg is no longer needed)
        cam[0, 0], cam[1, 0], cam[2, 0] = x0, x1, x2
        cam[0, 1], cam[1, 1], cam[2, 1] = z1 * x2 - z2 * x1, z2 * x0 - z0 * x2, z0 * x1 - z1 * x0
        cam[0, 2], cam[1, 2], cam[2, 2] = z0, z1, z2
        cam[0, 3], cam[1, 3], cam[2, 3] = a0, a1, a2
        cam[3, 0] = cam[3, 1] = cam[3, 2] = 0.0
        cam[3, 3] = 1.0
        # vTc . mount . cam
        mount = calib[C_MOUNT:C_SPAN].reshape((4, 4))
        _mul4(vTc, mount, out)
        _mul4(out, cam, vTc)
        vTg = vTc
    # the image's noise
    r = max(rng_m, 0.5)
    e0, e1, e2 = pos_noise * r * n[3], pos_noise * r * n[4], pos_noise * r * r * n[5]
    c0 = wTc[0, 0] * e0 + wTc[0, 1] * e1 + wTc[0, 2] * e2
    c1 = wTc[1, 0] * e0 + wTc[1, 1] * e1 + wTc[1, 2] * e2
    c2 = wTc[2, 0] * e0 + wTc[2, 1] * e1 + wTc[2, 2] * e2
    w0, w1, w2 = 0.1 * ang_noise * n[0], ang_noise * n[1], ang_noise * n[2]
    theta = math.sqrt(w0 * w0 + w1 * w1 + w2 * w2)
    # Rodrigues (kcl.rotations.so3_exp): I + s S + c S^2
    if theta < 1e-9:
        sa, ca = 1.0, 0.5
    else:
        sa, ca = math.sin(theta) / theta, (1.0 - math.cos(theta)) / theta**2
    S = ((0.0, -w2, w1), (w2, 0.0, -w0), (-w1, w0, 0.0))
    dR = np.empty((3, 3))
    for i in range(3):
        for j in range(3):
            s2 = S[i][0] * S[0][j] + S[i][1] * S[1][j] + S[i][2] * S[2][j]
            dR[i, j] = (1.0 if i == j else 0.0) + sa * S[i][j] + ca * s2
    for i in range(3):
        for j in range(3):
            out[i, j] = vTg[i, 0] * dR[0, j] + vTg[i, 1] * dR[1, j] + vTg[i, 2] * dR[2, j]
        out[i, 3] = vTg[i, 3] + (vTw[i, 0] * c0 + vTw[i, 1] * c1 + vTw[i, 2] * c2)
        out[3, i] = 0.0
    out[3, 3] = 1.0
