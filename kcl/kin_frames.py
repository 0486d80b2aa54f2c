"""Compiled frame poses and world Jacobians of the UVMS (the serial-chain
kinematics the task kernels read), without Pinocchio's Python bindings.

:func:`chain_buffers` takes, once per frame list, the numbers of the model's
free-flyer twin (joint placements, axes, frame placements, which joints move
which frame) into one int64 and one float64 buffer; :func:`frames_world`
then writes, for every frame of that list, its world pose ``P[i]`` (4x4) and
world Jacobian ``Jw[i]`` (6 x n, w.r.t. ``[qdot; v]``, joints first, linear
rows = velocity of the frame origin, both in world axes: Pinocchio's
``LOCAL_WORLD_ALIGNED``), in one compiled call. The controller's cycle
(:mod:`kcl.cycle`) runs it inside its one call per step.

Formulas (vehicle at ``p0 = eta[0:3]``, rotation ``wRv``; joint ``j`` with
world axis ``z_j`` through ``p_j``; frame origin ``p_f``): revolute column
``[z_j x (p_f - p_j); z_j]``, prismatic ``[z_j; 0]``, zero for joints not
moving the frame; body linear velocity ``[wRv; 0]``; body angular velocity
``[(wRv e_k) x (p_f - p0); wRv e_k]``. The same quantities as Pinocchio's
``computeJointJacobians`` + ``updateFramePlacement`` + ``getFrameJacobian``,
summed in another order: they agree to ~1e-15 (``tests/kcl/test_kin_frames.py``),
not bit for bit; the vehicle rotation is ``wRv`` (from the Euler angles, as
the task kernels use) where Pinocchio goes through the quaternion.

Supported joints: revolute and prismatic (axis-aligned or not) under a
free-flyer root with identity placement: what :meth:`kcl.model.UvmsModel.load`
accepts; :func:`chain_buffers` raises ValueError for anything else.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from kcl.buffers import take, take2, take3
from kcl.jit import njit

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


def chain_buffers(ff_model: Any, frame_ids: tuple[int, ...]) -> tuple[np.ndarray, np.ndarray]:
    """``(ibuf, fbuf)`` of the free-flyer Pinocchio model ``ff_model`` for the
    frames ``frame_ids`` (its frame indices); ValueError for a model this
    module does not cover. ``ibuf = [l, nf, parent (l; -1: the vehicle), kind (l),
    frame parent (nf), moves (nf x l, 0/1)]``; ``fbuf = [placement R (l x 9),
    placement p (l x 3), axis (l x 3), frame R (nf x 9), frame p (nf x 3),
    scratch (l x 15)]``."""
    njoints = ff_model.njoints
    if njoints < 2 or ff_model.joints[1].shortname() != "JointModelFreeFlyer":
        raise ValueError("the model's root joint is not a free flyer")
    root = ff_model.jointPlacements[1]
    if not (np.array_equal(root.rotation, np.eye(3)) and not np.any(root.translation)):
        raise ValueError("the free flyer's placement is not the identity")
    l = njoints - 2
    if ff_model.nv != l + 6:
        raise ValueError("the model has joints of more than one DOF")
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
            raise ValueError(f"joint {j} is of a kind the compiled chain does not cover")
        kind[j] = k
        parent[j] = ff_model.parents[pj] - 2  # -1: the free flyer (vehicle)
        if parent[j] < -1 or parent[j] >= j:
            raise ValueError(f"joint {j} comes before its parent")
        M = ff_model.jointPlacements[pj]
        jR[j] = np.asarray(M.rotation, dtype=float).reshape(9)
        jp[j] = np.asarray(M.translation, dtype=float)
        if name.endswith("Unaligned"):
            try:
                axis[j] = np.asarray(jm.extract().axis, dtype=float)
            except (AttributeError, TypeError, ValueError):  # (binding without the axis)
                raise ValueError(f"joint {j} has no readable axis") from None
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
            raise ValueError(f"frame {fid} is not attached to a joint")
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


@njit
def _place(
    R0: np.ndarray, px: float, py: float, pz: float, R: np.ndarray, t: np.ndarray, out: np.ndarray
) -> tuple[float, float, float]:
    """A child placement ``(R, t)`` on a parent pose (rotation ``R0``, origin
    ``(px, py, pz)``): the child rotation ``R0 R`` into ``out[:3, :3]``; returns
    its origin ``R0 t + p``."""
    for r in range(3):
        for c in range(3):
            out[r, c] = R0[r, 0] * R[0, c] + R0[r, 1] * R[1, c] + R0[r, 2] * R[2, c]
    t0, t1, t2 = t[0], t[1], t[2]
    x = R0[0, 0] * t0 + R0[0, 1] * t1 + R0[0, 2] * t2 + px
    y = R0[1, 0] * t0 + R0[1, 1] * t1 + R0[1, 2] * t2 + py
    z = R0[2, 0] * t0 + R0[2, 1] * t1 + R0[2, 2] * t2 + pz
    return x, y, z


@njit
def frames_world(
    q: np.ndarray, eta: np.ndarray, wRv: np.ndarray, kin_i: np.ndarray, kin_f: np.ndarray, P: np.ndarray, Jw: np.ndarray
) -> None:
    """``P[i]`` (4x4 world pose) and ``Jw[i]`` (6 x n world Jacobian, joints
    first) of every frame of the buffers of :func:`chain_buffers`, at joint
    positions ``q`` (rad), vehicle position ``eta[0:3]`` (m, NED) and rotation
    ``wRv``. ``P`` / ``Jw`` may hold more frames (left alone)."""
    l = kin_i[0]
    nf = kin_i[1]
    parent, o = take(kin_i, 2, l)
    kind, o = take(kin_i, o, l)
    fparent, o = take(kin_i, o, nf)
    moves, o = take2(kin_i, o, nf, l)
    jR, f = take3(kin_f, 0, l, 3, 3)
    jp, f = take2(kin_f, f, l, 3)
    axis, f = take2(kin_f, f, l, 3)
    fR, f = take3(kin_f, f, nf, 3, 3)
    fp, f = take2(kin_f, f, nf, 3)
    oR, f = take3(kin_f, f, l, 3, 3)  # scratch: joint frames in the world
    op, f = take2(kin_f, f, l, 3)
    oz, f = take2(kin_f, f, l, 3)  # joint axes in the world
    A = np.empty((3, 3))  # parent rotation @ placement
    M = np.empty((3, 3))  # joint motion
    for j in range(l):
        pj = parent[j]
        if pj < 0:
            x, y, z = _place(wRv, eta[0], eta[1], eta[2], jR[j], jp[j], A)
        else:
            x, y, z = _place(oR[pj], op[pj, 0], op[pj, 1], op[pj, 2], jR[j], jp[j], A)
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
        Pi = P[i]
        if pj < 0:
            fx, fy, fz = _place(wRv, eta[0], eta[1], eta[2], fR[i], fp[i], Pi)
        else:
            fx, fy, fz = _place(oR[pj], op[pj, 0], op[pj, 1], op[pj, 2], fR[i], fp[i], Pi)
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
