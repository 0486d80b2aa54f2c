"""Compiled frame poses and world Jacobians of the UVMS (the serial-chain
kinematics the task kernels read), without Pinocchio's Python bindings.

:func:`chain_buffers` takes, once per frame list, the numbers of the model's
free-flyer twin (joint placements, axes, frame placements, which joints move
which frame) into one int64 and one float64 buffer; :func:`frames_world`
then writes, for every frame of that list, its world pose ``P[i]`` (4x4) and
world Jacobian ``Jw[i]`` (6 x n, w.r.t. ``[qdot; v]``, joints first, linear
rows = velocity of the frame origin, both in world axes: Pinocchio's
``LOCAL_WORLD_ALIGNED``), in one compiled call. :func:`kcl.arm_cycle.arm_cycle`
runs it inside the arm step's one call; :meth:`kcl.model.Kinematics.frames_into`
uses it for the task batch.

Formulas (vehicle at ``p0 = eta[0:3]``, rotation ``wRv``; joint ``j`` with
world axis ``z_j`` through ``p_j``; frame origin ``p_f``): revolute column
``[z_j x (p_f - p_j); z_j]``, prismatic ``[z_j; 0]``, zero for joints not
moving the frame; body linear velocity ``[wRv; 0]``; body angular velocity
``[(wRv e_k) x (p_f - p0); wRv e_k]``. The same quantities as Pinocchio's
``computeJointJacobians`` + ``updateFramePlacement`` + ``getFrameJacobian``,
summed in another order: they agree to ~1e-15 (``tests/kcl/test_kin_frames.py``),
not bit for bit; the vehicle rotation is ``wRv`` (from the Euler angles, as
the task kernels use) where Pinocchio goes through the quaternion.

Supported joints: revolute and prismatic (axis-aligned or not), a free-flyer
root with identity placement (what :meth:`kcl.model.UvmsModel.load` accepts);
:func:`chain_buffers` returns None otherwise and the callers keep Pinocchio.
"""

from __future__ import annotations

import math

import numpy as np

from kcl.jit_cache import KERNEL_OPTIONS

try:
    import numba
except ImportError:  # pragma: no cover - the callers keep Pinocchio
    numba = None


def _njit(fn):
    """``numba.njit(**KERNEL_OPTIONS)`` (:data:`kcl.jit_cache.KERNEL_OPTIONS`; this
    module calls no other compiled function: its cache never goes stale through
    another file); without Numba, ``fn`` itself (plain Python, slow: tests only)."""
    return fn if numba is None else numba.njit(**KERNEL_OPTIONS)(fn)


#: joint kinds in the int buffer
_RX, _RY, _RZ, _REV, _PRIS = 0, 1, 2, 3, 4
_KINDS = {
    "JointModelRX": _RX,
    "JointModelRY": _RY,
    "JointModelRZ": _RZ,
    "JointModelRevoluteUnaligned": _REV,
    "JointModelPX": _PRIS,
    "JointModelPY": _PRIS,
    "JointModelPZ": _PRIS,
    "JointModelPrismaticUnaligned": _PRIS,
}
_AXES = {"X": (1.0, 0.0, 0.0), "Y": (0.0, 1.0, 0.0), "Z": (0.0, 0.0, 1.0)}


def chain_buffers(ff_model, frame_ids: tuple[int, ...]) -> tuple[np.ndarray, np.ndarray] | None:
    """``(ibuf, fbuf)`` of the free-flyer Pinocchio model ``ff_model`` for the
    frames ``frame_ids`` (its frame indices), or None for a model this module
    does not cover. ``ibuf = [l, nf, parent (l; -1: the vehicle), kind (l),
    frame parent (nf), moves (nf x l, 0/1)]``; ``fbuf = [placement R (l x 9),
    placement p (l x 3), axis (l x 3), frame R (nf x 9), frame p (nf x 3),
    scratch (l x 15)]``."""
    njoints = ff_model.njoints
    if njoints < 2 or ff_model.joints[1].shortname() != "JointModelFreeFlyer":
        return None
    root = ff_model.jointPlacements[1]
    if not (np.array_equal(root.rotation, np.eye(3)) and not np.any(root.translation)):
        return None
    l = njoints - 2
    if ff_model.nv != l + 6:
        return None
    nf = len(frame_ids)
    parent = np.zeros(l, dtype=np.int64)
    kind = np.zeros(l, dtype=np.int64)
    jR = np.zeros((l, 9))
    jp = np.zeros((l, 3))
    axis = np.zeros((l, 3))
    for j in range(l):
        pj = 2 + j  # Pinocchio joint index (0: universe, 1: the free flyer)
        jm = ff_model.joints[pj]
        name = jm.shortname()
        k = _KINDS.get(name)
        if k is None or ff_model.idx_vs[pj] != 6 + j or ff_model.idx_qs[pj] != 7 + j:
            return None
        kind[j] = k
        parent[j] = ff_model.parents[pj] - 2  # -1: the free flyer (vehicle)
        if parent[j] < -1 or parent[j] >= j:
            return None
        M = ff_model.jointPlacements[pj]
        jR[j] = np.asarray(M.rotation, dtype=float).reshape(9)
        jp[j] = np.asarray(M.translation, dtype=float)
        if name.endswith("Unaligned"):
            try:
                axis[j] = np.asarray(jm.extract().axis, dtype=float)
            except (AttributeError, TypeError, ValueError):  # (binding without the axis)
                return None
        else:
            axis[j] = _AXES[name[-1]]
    fparent = np.zeros(nf, dtype=np.int64)
    moves = np.zeros((nf, l), dtype=np.int64)
    fR = np.zeros((nf, 9))
    fp = np.zeros((nf, 3))
    for i, fid in enumerate(frame_ids):
        fr = ff_model.frames[fid]
        pj = int(fr.parentJoint)
        if pj < 1:
            return None
        fparent[i] = pj - 2
        fR[i] = np.asarray(fr.placement.rotation, dtype=float).reshape(9)
        fp[i] = np.asarray(fr.placement.translation, dtype=float)
        j = pj - 2
        while j >= 0:
            moves[i, j] = 1
            j = parent[j]
    ibuf = np.concatenate([np.array([l, nf], dtype=np.int64), parent, kind, fparent, moves.reshape(-1)])
    fbuf = np.concatenate(
        [jR.reshape(-1), jp.reshape(-1), axis.reshape(-1), fR.reshape(-1), fp.reshape(-1), np.zeros(15 * l)]
    )
    return ibuf, fbuf


@_njit
def frames_world(q, eta, wRv, kin_i, kin_f, P, Jw):
    """``P[i]`` (4x4 world pose) and ``Jw[i]`` (6 x n world Jacobian, joints
    first) of every frame of the buffers of :func:`chain_buffers`, at joint
    positions ``q`` (rad), vehicle position ``eta[0:3]`` (m, NED) and rotation
    ``wRv``. ``P`` / ``Jw`` may hold more frames (left alone)."""
    l = kin_i[0]
    nf = kin_i[1]
    o = 2
    parent = kin_i[o : o + l]
    o += l
    kind = kin_i[o : o + l]
    o += l
    fparent = kin_i[o : o + nf]
    o += nf
    moves = kin_i[o : o + nf * l].reshape((nf, l))
    f = 0
    jR = kin_f[f : f + 9 * l].reshape((l, 3, 3))
    f += 9 * l
    jp = kin_f[f : f + 3 * l].reshape((l, 3))
    f += 3 * l
    axis = kin_f[f : f + 3 * l].reshape((l, 3))
    f += 3 * l
    fR = kin_f[f : f + 9 * nf].reshape((nf, 3, 3))
    f += 9 * nf
    fp = kin_f[f : f + 3 * nf].reshape((nf, 3))
    f += 3 * nf
    oR = kin_f[f : f + 9 * l].reshape((l, 3, 3))  # scratch: joint frames in the world
    f += 9 * l
    op = kin_f[f : f + 3 * l].reshape((l, 3))
    f += 3 * l
    oz = kin_f[f : f + 3 * l].reshape((l, 3))  # joint axes in the world
    A = np.empty((3, 3))  # parent rotation @ placement
    M = np.empty((3, 3))  # joint motion
    for j in range(l):
        pj = parent[j]
        # parent pose
        if pj < 0:
            R0 = wRv
            px, py, pz = eta[0], eta[1], eta[2]
        else:
            R0 = oR[pj]
            px, py, pz = op[pj, 0], op[pj, 1], op[pj, 2]
        Rp = jR[j]
        for r in range(3):
            for c in range(3):
                A[r, c] = R0[r, 0] * Rp[0, c] + R0[r, 1] * Rp[1, c] + R0[r, 2] * Rp[2, c]
        t0, t1, t2 = jp[j, 0], jp[j, 1], jp[j, 2]
        x = R0[0, 0] * t0 + R0[0, 1] * t1 + R0[0, 2] * t2 + px
        y = R0[1, 0] * t0 + R0[1, 1] * t1 + R0[1, 2] * t2 + py
        z = R0[2, 0] * t0 + R0[2, 1] * t1 + R0[2, 2] * t2 + pz
        ax, ay, az = axis[j, 0], axis[j, 1], axis[j, 2]
        # world axis
        oz[j, 0] = A[0, 0] * ax + A[0, 1] * ay + A[0, 2] * az
        oz[j, 1] = A[1, 0] * ax + A[1, 1] * ay + A[1, 2] * az
        oz[j, 2] = A[2, 0] * ax + A[2, 1] * ay + A[2, 2] * az
        k = kind[j]
        if k == _PRIS:
            qj = q[j]
            op[j, 0] = x + oz[j, 0] * qj
            op[j, 1] = y + oz[j, 1] * qj
            op[j, 2] = z + oz[j, 2] * qj
            for r in range(3):
                for c in range(3):
                    oR[j, r, c] = A[r, c]
            continue
        op[j, 0] = x
        op[j, 1] = y
        op[j, 2] = z
        cq = math.cos(q[j])
        sq = math.sin(q[j])
        if k == _RX:
            M[0, 0], M[0, 1], M[0, 2] = 1.0, 0.0, 0.0
            M[1, 0], M[1, 1], M[1, 2] = 0.0, cq, -sq
            M[2, 0], M[2, 1], M[2, 2] = 0.0, sq, cq
        elif k == _RY:
            M[0, 0], M[0, 1], M[0, 2] = cq, 0.0, sq
            M[1, 0], M[1, 1], M[1, 2] = 0.0, 1.0, 0.0
            M[2, 0], M[2, 1], M[2, 2] = -sq, 0.0, cq
        elif k == _RZ:
            M[0, 0], M[0, 1], M[0, 2] = cq, -sq, 0.0
            M[1, 0], M[1, 1], M[1, 2] = sq, cq, 0.0
            M[2, 0], M[2, 1], M[2, 2] = 0.0, 0.0, 1.0
        else:  # Rodrigues about the unit axis
            v = 1.0 - cq
            M[0, 0] = cq + v * ax * ax
            M[0, 1] = v * ax * ay - sq * az
            M[0, 2] = v * ax * az + sq * ay
            M[1, 0] = v * ax * ay + sq * az
            M[1, 1] = cq + v * ay * ay
            M[1, 2] = v * ay * az - sq * ax
            M[2, 0] = v * ax * az - sq * ay
            M[2, 1] = v * ay * az + sq * ax
            M[2, 2] = cq + v * az * az
        for r in range(3):
            for c in range(3):
                oR[j, r, c] = A[r, 0] * M[0, c] + A[r, 1] * M[1, c] + A[r, 2] * M[2, c]
    for i in range(nf):
        pj = fparent[i]
        if pj < 0:
            R0 = wRv
            px, py, pz = eta[0], eta[1], eta[2]
        else:
            R0 = oR[pj]
            px, py, pz = op[pj, 0], op[pj, 1], op[pj, 2]
        Rf = fR[i]
        Pi = P[i]
        for r in range(3):
            for c in range(3):
                Pi[r, c] = R0[r, 0] * Rf[0, c] + R0[r, 1] * Rf[1, c] + R0[r, 2] * Rf[2, c]
        t0, t1, t2 = fp[i, 0], fp[i, 1], fp[i, 2]
        fx = R0[0, 0] * t0 + R0[0, 1] * t1 + R0[0, 2] * t2 + px
        fy = R0[1, 0] * t0 + R0[1, 1] * t1 + R0[1, 2] * t2 + py
        fz = R0[2, 0] * t0 + R0[2, 1] * t1 + R0[2, 2] * t2 + pz
        Pi[0, 3] = fx
        Pi[1, 3] = fy
        Pi[2, 3] = fz
        Pi[3, 0] = 0.0
        Pi[3, 1] = 0.0
        Pi[3, 2] = 0.0
        Pi[3, 3] = 1.0
        Ji = Jw[i]
        for j in range(l):
            if moves[i, j] == 0:
                for r in range(6):
                    Ji[r, j] = 0.0
                continue
            zx, zy, zz = oz[j, 0], oz[j, 1], oz[j, 2]
            if kind[j] == _PRIS:
                Ji[0, j] = zx
                Ji[1, j] = zy
                Ji[2, j] = zz
                Ji[3, j] = 0.0
                Ji[4, j] = 0.0
                Ji[5, j] = 0.0
            else:
                dx = fx - op[j, 0]
                dy = fy - op[j, 1]
                dz = fz - op[j, 2]
                Ji[0, j] = zy * dz - zz * dy
                Ji[1, j] = zz * dx - zx * dz
                Ji[2, j] = zx * dy - zy * dx
                Ji[3, j] = zx
                Ji[4, j] = zy
                Ji[5, j] = zz
        dx = fx - eta[0]
        dy = fy - eta[1]
        dz = fz - eta[2]
        for c in range(3):
            wx, wy, wz = wRv[0, c], wRv[1, c], wRv[2, c]
            # body linear velocity
            Ji[0, l + c] = wx
            Ji[1, l + c] = wy
            Ji[2, l + c] = wz
            Ji[3, l + c] = 0.0
            Ji[4, l + c] = 0.0
            Ji[5, l + c] = 0.0
            # body angular velocity
            Ji[0, l + 3 + c] = wy * dz - wz * dy
            Ji[1, l + 3 + c] = wz * dx - wx * dz
            Ji[2, l + 3 + c] = wx * dy - wy * dx
            Ji[3, l + 3 + c] = wx
            Ji[4, l + 3 + c] = wy
            Ji[5, l + 3 + c] = wz


def _warm_up() -> None:
    kin_i = np.array([1, 1, -1, _RZ, 0, 1], dtype=np.int64)
    kin_f = np.zeros(9 + 3 + 3 + 9 + 3 + 15)
    frames_world(np.zeros(1), np.zeros(6), np.eye(3), kin_i, kin_f, np.zeros((1, 4, 4)), np.zeros((1, 6, 7)))


if numba is not None:
    _warm_up()  # load (first time: compile) now, not in a control cycle
    frames_world.disable_compile()  # other argument kinds raise TypeError: the callers' Pinocchio path
