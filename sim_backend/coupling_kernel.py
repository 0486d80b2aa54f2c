"""The arm-vehicle coupling terms of :mod:`sim_backend.coupling`, compiled.

Every 10 ms step the full vehicle needs, for a floating base carrying a serial
arm of revolute joints, ``M_bb`` (6, 6): the inertia of the whole system at the
vehicle frame with the joints locked, and ``b`` (6,) = ``M_bq qddot + h_b``:
the base rows of the inverse dynamics with zero base acceleration (the reaction
of the accelerating links plus the Coriolis and centrifugal terms, hull
included; no gravity). Pinocchio's ``crba`` and ``rnea`` compute them in a few
microseconds but the Python binding costs about ten times the arithmetic;
:func:`coupling_terms` does the same recursions in one compiled call on the
model's numbers (:func:`pack_model`, read from the Pinocchio model once).

Conventions are Pinocchio's: spatial vectors ``[linear; angular]`` in each
body's own frame, the free flyer's velocity the body velocity ``[v; w]`` of the
vehicle frame. The sums run in another order than Pinocchio's, so the terms
agree with it to rounding (~1e-15 relative; ``tests/sim_backend/test_coupling_kernel.py``
compares them over random configurations), not bit for bit.

Model rows ``geo[j]`` (``G_*`` columns): body 0 is the vehicle (only its
inertia is used), body ``j`` >= 1 hangs on joint ``j - 1`` from body ``j - 1``:
the joint's placement in the parent (rotation ``G_R`` row-major 3x3,
translation ``G_P``), its unit axis ``G_AXIS`` (joint frame), the body's mass
``G_M`` (kg), centre of mass ``G_C`` (m, body frame) and rotational inertia
about it ``G_I`` (kg m^2, row-major 3x3). ``work`` (bodies, ``N_W``): scratch.
"""

from __future__ import annotations

import math

import numpy as np
import pinocchio as pin
from numba import njit

G_R, G_P, G_AXIS, G_M, G_C, G_I = 0, 9, 12, 15, 16, 19
N_G = 28
# work columns: local rotation (body in parent), absolute rotation and position
# (body in vehicle frame), velocity, acceleration, force
W_LR, W_R, W_P, W_V, W_A, W_F = 0, 9, 18, 21, 27, 33
N_W = 39


def pack_model(model: object) -> np.ndarray:
    """``geo`` rows of a Pinocchio model with a free-flyer root (joint 1) carrying a
    serial chain of revolute joints (2, 3, ...: each the parent of the next).
    Raises ``ValueError`` for another structure."""

    nj = model.njoints  # type: ignore[attr-defined]
    n = nj - 2
    geo = np.zeros((n + 1, N_G))
    for b in range(n + 1):
        j = b + 1
        if b > 0:
            if model.parents[j] != j - 1:  # type: ignore[attr-defined]
                raise ValueError("coupling kernel: the arm must be a serial chain")
            jm = model.joints[j]  # type: ignore[attr-defined]
            name = jm.shortname()
            axes = {"JointModelRX": (1.0, 0.0, 0.0), "JointModelRY": (0.0, 1.0, 0.0), "JointModelRZ": (0.0, 0.0, 1.0)}
            if name in axes:
                axis = np.array(axes[name])
            elif name == "JointModelRevoluteUnaligned":
                axis = np.asarray(jm.extract().axis, dtype=float)
            else:
                raise ValueError(f"coupling kernel: joint {j} is {name}, not revolute")
            pl = model.jointPlacements[j]  # type: ignore[attr-defined]
            geo[b, G_R : G_R + 9] = np.asarray(pl.rotation).reshape(9)
            geo[b, G_P : G_P + 3] = pl.translation
            geo[b, G_AXIS : G_AXIS + 3] = axis
        elif not isinstance(model.joints[1].extract(), pin.JointModelFreeFlyer):  # type: ignore[attr-defined]
            raise ValueError("coupling kernel: joint 1 must be a free flyer")
        inertia = model.inertias[j]  # type: ignore[attr-defined]
        geo[b, G_M] = inertia.mass
        geo[b, G_C : G_C + 3] = inertia.lever
        geo[b, G_I : G_I + 9] = np.asarray(inertia.inertia).reshape(9)
    return geo


@njit(cache=True)
def _inertia_times(g: np.ndarray, v: np.ndarray, vi: int, out: np.ndarray, oi: int) -> None:
    """``out[oi:oi + 6] = I v[vi:vi + 6]`` for the body inertia of row ``g``
    (linear ``m (v - c x w)``, angular ``Ic w + c x linear``)."""
    m = g[G_M]
    cx, cy, cz = g[G_C], g[G_C + 1], g[G_C + 2]
    wx, wy, wz = v[vi + 3], v[vi + 4], v[vi + 5]
    lx = m * (v[vi] - (cy * wz - cz * wy))
    ly = m * (v[vi + 1] - (cz * wx - cx * wz))
    lz = m * (v[vi + 2] - (cx * wy - cy * wx))
    out[oi] = lx
    out[oi + 1] = ly
    out[oi + 2] = lz
    for r in range(3):
        out[oi + 3 + r] = g[G_I + 3 * r] * wx + g[G_I + 3 * r + 1] * wy + g[G_I + 3 * r + 2] * wz
    out[oi + 3] += cy * lz - cz * ly
    out[oi + 4] += cz * lx - cx * lz
    out[oi + 5] += cx * ly - cy * lx


@njit(cache=True)
def _body_force(g: np.ndarray, w: np.ndarray) -> None:
    """``f = I a + v x* (I v)`` of one body (its work row ``w``) into ``w[W_F:]``."""
    h = np.empty(6)
    _inertia_times(g, w, W_V, h, 0)
    _inertia_times(g, w, W_A, w, W_F)
    vx, vy, vz = w[W_V], w[W_V + 1], w[W_V + 2]
    wx, wy, wz = w[W_V + 3], w[W_V + 4], w[W_V + 5]
    w[W_F] += wy * h[2] - wz * h[1]
    w[W_F + 1] += wz * h[0] - wx * h[2]
    w[W_F + 2] += wx * h[1] - wy * h[0]
    w[W_F + 3] += wy * h[5] - wz * h[4] + vy * h[2] - vz * h[1]
    w[W_F + 4] += wz * h[3] - wx * h[5] + vz * h[0] - vx * h[2]
    w[W_F + 5] += wx * h[4] - wy * h[3] + vx * h[1] - vy * h[0]


@njit(cache=True)
def coupling_terms(
    q: np.ndarray,
    qdot: np.ndarray,
    qddot: np.ndarray,
    nu: np.ndarray,
    inertia: bool,
    geo: np.ndarray,
    work: np.ndarray,
    Mbb: np.ndarray,
    bias: np.ndarray,
) -> None:
    """``b`` into ``bias`` (6,) (N, N m, vehicle frame) for joint positions ``q`` (rad),
    velocities ``qdot`` (rad/s), accelerations ``qddot`` (rad/s^2) and the vehicle's
    body velocity ``nu`` (6,); when ``inertia``, also ``M_bb`` into ``Mbb`` (6, 6, full)."""
    n = q.shape[0]
    for k in range(6):
        work[0, W_V + k] = nu[k]
        work[0, W_A + k] = 0.0
    for i in range(9):
        work[0, W_R + i] = 1.0 if i % 4 == 0 else 0.0
    for i in range(3):
        work[0, W_P + i] = 0.0
    for b in range(1, n + 1):
        g, w, wp = geo[b], work[b], work[b - 1]
        j = b - 1
        # local rotation: placement times the joint's rotation about its axis (Rodrigues)
        sx, sy, sz = g[G_AXIS], g[G_AXIS + 1], g[G_AXIS + 2]
        c, s = math.cos(q[j]), math.sin(q[j])
        t = 1.0 - c
        rj = (
            t * sx * sx + c,
            t * sx * sy - s * sz,
            t * sx * sz + s * sy,
            t * sx * sy + s * sz,
            t * sy * sy + c,
            t * sy * sz - s * sx,
            t * sx * sz - s * sy,
            t * sy * sz + s * sx,
            t * sz * sz + c,
        )
        for r in range(3):
            for col in range(3):
                w[W_LR + 3 * r + col] = (
                    g[G_R + 3 * r] * rj[col] + g[G_R + 3 * r + 1] * rj[3 + col] + g[G_R + 3 * r + 2] * rj[6 + col]
                )
        px, py, pz = g[G_P], g[G_P + 1], g[G_P + 2]
        # velocity and acceleration: the parent's seen from this body, plus the joint's
        for base in (W_V, W_A):
            lx, ly, lz = wp[base], wp[base + 1], wp[base + 2]
            ax, ay, az = wp[base + 3], wp[base + 4], wp[base + 5]
            ux = lx + (ay * pz - az * py)
            uy = ly + (az * px - ax * pz)
            uz = lz + (ax * py - ay * px)
            for r in range(3):
                w[base + r] = w[W_LR + r] * ux + w[W_LR + 3 + r] * uy + w[W_LR + 6 + r] * uz
                w[base + 3 + r] = w[W_LR + r] * ax + w[W_LR + 3 + r] * ay + w[W_LR + 6 + r] * az
        qd, qdd = qdot[j], qddot[j]
        w[W_V + 3] += sx * qd
        w[W_V + 4] += sy * qd
        w[W_V + 5] += sz * qd
        # v x (S qdot): linear v_lin x (s qd), angular w x (s qd)
        mx, my, mz = sx * qd, sy * qd, sz * qd
        vx, vy, vz = w[W_V], w[W_V + 1], w[W_V + 2]
        wx, wy, wz = w[W_V + 3], w[W_V + 4], w[W_V + 5]
        w[W_A] += vy * mz - vz * my
        w[W_A + 1] += vz * mx - vx * mz
        w[W_A + 2] += vx * my - vy * mx
        w[W_A + 3] += sx * qdd + (wy * mz - wz * my)
        w[W_A + 4] += sy * qdd + (wz * mx - wx * mz)
        w[W_A + 5] += sz * qdd + (wx * my - wy * mx)
        if inertia:  # the body's pose in the vehicle frame
            for r in range(3):
                for col in range(3):
                    w[W_R + 3 * r + col] = (
                        wp[W_R + 3 * r] * w[W_LR + col]
                        + wp[W_R + 3 * r + 1] * w[W_LR + 3 + col]
                        + wp[W_R + 3 * r + 2] * w[W_LR + 6 + col]
                    )
                w[W_P + r] = wp[W_R + 3 * r] * px + wp[W_R + 3 * r + 1] * py + wp[W_R + 3 * r + 2] * pz + wp[W_P + r]
    for b in range(n + 1):
        _body_force(geo[b], work[b])
    for b in range(n, 0, -1):  # forces back to the parent: f_p += R f, p x (R f) + R tau
        g, w, wp = geo[b], work[b], work[b - 1]
        px, py, pz = g[G_P], g[G_P + 1], g[G_P + 2]
        fl = np.empty(3)
        for r in range(3):
            fl[r] = w[W_LR + 3 * r] * w[W_F] + w[W_LR + 3 * r + 1] * w[W_F + 1] + w[W_LR + 3 * r + 2] * w[W_F + 2]
            wp[W_F + r] += fl[r]
        for r in range(3):
            wp[W_F + 3 + r] += (
                w[W_LR + 3 * r] * w[W_F + 3] + w[W_LR + 3 * r + 1] * w[W_F + 4] + w[W_LR + 3 * r + 2] * w[W_F + 5]
            )
        wp[W_F + 3] += py * fl[2] - pz * fl[1]
        wp[W_F + 4] += pz * fl[0] - px * fl[2]
        wp[W_F + 5] += px * fl[1] - py * fl[0]
    for k in range(6):
        bias[k] = work[0, W_F + k]
    if not inertia:
        return
    # M_bb: every body's inertia moved to the vehicle frame and summed
    m_tot, mc, io = 0.0, np.zeros(3), np.zeros(9)
    for b in range(n + 1):
        g, w = geo[b], work[b]
        m = g[G_M]
        c0 = np.empty(3)
        for r in range(3):
            c0[r] = (
                w[W_R + 3 * r] * g[G_C] + w[W_R + 3 * r + 1] * g[G_C + 1] + w[W_R + 3 * r + 2] * g[G_C + 2] + w[W_P + r]
            )
        m_tot += m
        for r in range(3):
            mc[r] += m * c0[r]
        cc = c0[0] * c0[0] + c0[1] * c0[1] + c0[2] * c0[2]
        for r in range(3):
            for col in range(3):
                acc = 0.0  # (R Ic R^T)[r, col]
                for k in range(3):
                    ric = (
                        w[W_R + 3 * r] * g[G_I + k]
                        + w[W_R + 3 * r + 1] * g[G_I + 3 + k]
                        + w[W_R + 3 * r + 2] * g[G_I + 6 + k]
                    )
                    acc += ric * w[W_R + 3 * col + k]
                io[3 * r + col] += acc + m * ((cc if r == col else 0.0) - c0[r] * c0[col])
    for r in range(3):
        for col in range(3):
            Mbb[r, col] = m_tot if r == col else 0.0
            Mbb[3 + r, 3 + col] = io[3 * r + col] if r <= col else io[3 * col + r]  # exactly symmetric
    # linear-angular blocks: upper right -m [c]x, lower left m [c]x
    cx, cy, cz = mc[0], mc[1], mc[2]
    Mbb[3, 0], Mbb[3, 1], Mbb[3, 2] = 0.0, -cz, cy
    Mbb[4, 0], Mbb[4, 1], Mbb[4, 2] = cz, 0.0, -cx
    Mbb[5, 0], Mbb[5, 1], Mbb[5, 2] = -cy, cx, 0.0
    for r in range(3):
        for col in range(3):
            Mbb[r, 3 + col] = Mbb[3 + col, r]


@njit(cache=True)
def coupling_step(
    h: float,
    q: np.ndarray,
    qdot: np.ndarray,
    qdot_prev: np.ndarray,
    qddot: np.ndarray,
    nu: np.ndarray,
    first: bool,
    geo: np.ndarray,
    work: np.ndarray,
    Mbb: np.ndarray,
    bias: np.ndarray,
) -> None:
    """One step's coupling: ``qddot = (qdot - qdot_prev) * (1 / h)`` (rad/s^2, the
    drives' finite difference over the step ``h`` s), ``qdot_prev = qdot``, then
    :func:`coupling_terms`; ``M_bb`` is recomputed only when a joint moves (or
    ``first``): the joint positions change only then."""
    inv_h = 1.0 / h
    moved = first
    for j in range(q.shape[0]):
        d = qdot[j] - qdot_prev[j]
        d *= inv_h
        qddot[j] = d
        qdot_prev[j] = qdot[j]
        if qdot[j] != 0.0:
            moved = True
    coupling_terms(q, qdot, qddot, nu, moved, geo, work, Mbb, bias)
