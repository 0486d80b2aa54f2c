"""TPIK 2's steady cycle from the task kernels to the clipped joint velocities
in ONE compiled call (:func:`arm_cycle`), taking its many arrays packed in a
few buffers.

A compiled call costs ~300 instructions per array argument (type check and
unboxing in Numba's dispatcher). The steady arm step used to make two calls,
:func:`kcl.tasks.batch.run_rows` (18 arguments) and
:func:`kcl.cycle.gather_solve` (29); :func:`arm_cycle` runs both, in the same
order on the same arrays (the same numbers, bit for bit), taking 16
arguments: the :class:`kcl.tasks.batch.TaskBatch`, the
:class:`kcl.icat_stacked.StackedLevels` and the steady layout each hand over
one int64 and one float64 buffer, of which all their arrays are views
(:func:`kcl.tasks.batch.batch_views`, :func:`stack_views`, :func:`layout_views`
carve them again inside the compiled code, no copy).

:meth:`kcl.stacking.StackingMixin._arm_cycle` is the Python side. Numba's cache
of :func:`arm_cycle` embeds the functions it calls (other files):
:func:`kcl.jit_cache.drop_stale` discards it when one of them is newer.
"""

from __future__ import annotations

import numpy as np

from kcl import cycle as _cycle
from kcl import icat_kernel, kin_frames, kin_kernel, small_linalg
from kcl.cycle import gather_solve, inputs_finite
from kcl.jit_cache import drop_stale
from kcl.kin_frames import frames_world
from kcl.kin_kernel import configure
from kcl.tasks import batch as _batch
from kcl.tasks.batch import batch_views, run_rows
from kcl.tasks.jit import SHARED_SOURCES, njit

drop_stale(
    __file__,
    [
        __file__,
        _cycle.__file__,
        _batch.__file__,
        icat_kernel.__file__,
        small_linalg.__file__,
        kin_frames.__file__,
        kin_kernel.__file__,
    ]
    + _batch.KERNEL_SOURCES
    + SHARED_SOURCES,
)


def layout_buffers(
    slots: list[int], level_of: list[int], inequality: list[bool], lams: list[float], ths: list[float]
) -> tuple[np.ndarray, np.ndarray]:
    """``(ibuf, fbuf)`` of a steady layout (see :func:`layout_views`), zeroed work arrays."""
    s, n_levels = len(slots), len(lams)
    ibuf = np.zeros(2 + 4 * s + n_levels, dtype=np.int64)
    ibuf[:2] = (s, n_levels)
    ibuf[2 : 2 + 3 * s] = list(slots) + list(level_of) + [int(bool(x)) for x in inequality]
    fbuf = np.array(list(lams) + list(ths), dtype=float).reshape(2 * n_levels)
    return ibuf, fbuf


@njit
def layout_views(ibuf, fbuf):
    """``(slots, level_of, inequality, level_rows, slot_row, level_lams, level_ths)``
    of a steady layout: ``ibuf = [S, L, slots (S), level_of (S), inequality (S,
    0/1), level_rows (L), slot_row (S)]``, ``fbuf = [lams (L), ths (L)]``."""
    s, n_levels = ibuf[0], ibuf[1]
    o = 2
    slots = ibuf[o : o + s]
    o += s
    level_of = ibuf[o : o + s]
    o += s
    inequality = ibuf[o : o + s]
    o += s
    level_rows = ibuf[o : o + n_levels]
    o += n_levels
    slot_row = ibuf[o : o + s]
    return slots, level_of, inequality, level_rows, slot_row, fbuf[:n_levels], fbuf[n_levels : 2 * n_levels]


@njit
def stack_views(ibuf, fbuf):
    """The arrays of a :class:`kcl.icat_stacked.StackedLevels` from its two
    buffers (same layout as its constructor): ``(J, a, xdot, lams, ths, raw,
    applied, factors, offsets, level_ids)``, views."""
    rows, n, max_levels = ibuf[0], ibuf[1], ibuf[2]
    levels = max(1, max_levels)
    o = rows * n
    J = fbuf[:o].reshape((rows, n))
    a = fbuf[o : o + rows]
    o += rows
    xdot = fbuf[o : o + rows]
    o += rows
    lams = fbuf[o : o + levels]
    o += levels
    ths = fbuf[o : o + levels]
    o += levels
    k = (max_levels + 1) * n
    raw = fbuf[o : o + k].reshape((max_levels + 1, n))
    o += k
    applied = fbuf[o : o + k].reshape((max_levels + 1, n))
    o += k
    factors = fbuf[o : o + max_levels + 1]
    offsets = ibuf[3 : 3 + max_levels + 1]
    level_ids = ibuf[3 + max_levels + 1 :]
    return J, a, xdot, lams, ths, raw, applied, factors, offsets, level_ids


#: :func:`arm_cycle`'s ``frames`` argument: the batch's P / Jw are up to date
FRAMES_READY = 0
#: Pinocchio's Jacobians are in the batch's raw array (``Kinematics.frames_into(..., reorder=False)``)
FRAMES_REORDER = 1
#: compute every frame of the batch (:func:`kcl.kin_frames.frames_world` with ``kin_i`` / ``kin_f``)
FRAMES_COMPUTE = 2
#: :func:`arm_cycle`'s first result when its input check (``prep``) found a
#: non-finite input: nothing was changed
INPUTS_NOT_FINITE = -1


@njit
def arm_cycle(
    batch_i,
    batch_f,
    selected,
    q,
    eta,
    wRv,
    lay_i,
    lay_f,
    stack_i,
    stack_f,
    v_top,
    limits,
    out,
    lam_mv,
    th_mv,
    eta_w,
    frames_mode,
    kin_i,
    kin_f,
    v_meas,
    qff,
    t_meas,
    altitude,
    k,
    prep,
):
    """With ``prep`` (1 or 2; 0: none), first the controller's input work of
    the step (:meth:`kcl.controller_arm.FusedArmMixin._arm_fused`): the
    finiteness test of :func:`kcl.cycle.finite_total` on ``q``, ``eta``,
    ``v_meas``, ``t_meas``, ``altitude`` (returns :data:`INPUTS_NOT_FINITE`
    at once when it fails), with ``prep == 2`` the low-pass step of
    :func:`kcl.filters._lowpass_step` on ``v_top`` (the filter state) towards
    ``v_meas`` with gain ``k``, then ``wRv`` (and ``qff``) by
    :func:`kcl.kin_kernel.configure`: the same operations as those calls.

    Then the batch's frames as ``frames_mode`` says (:data:`FRAMES_READY`,
    :data:`FRAMES_REORDER`: Pinocchio's columns reordered, :data:`FRAMES_COMPUTE`:
    computed from ``kin_i`` / ``kin_f``, the buffers of
    :func:`kcl.kin_frames.chain_buffers` for the batch's frame names); then
    :func:`kcl.tasks.batch.run_rows` on the batch's selected tasks, then
    :func:`kcl.cycle.gather_solve` into the stack with the layout; returns
    gather_solve's tuple (``out``: the clipped joint velocities, rad/s)."""
    if prep:
        if not inputs_finite(q, eta, v_meas, t_meas, altitude):
            return INPUTS_NOT_FINITE, 0, 0, False, -1, 0
        if prep == 2:
            for i in range(v_top.shape[0]):
                v_top[i] += k * (v_meas[i] - v_top[i])
        configure(q, eta, wRv, qff)
    ids, frames, row0, dims, status, X, J, A, XD, E, P, Jw, Jraw, env, params = batch_views(batch_i, batch_f)
    if frames_mode == 2:
        frames_world(q, eta, wRv, kin_i, kin_f, P, Jw)
    elif (
        frames_mode == 1
    ):  # Pinocchio's columns (base first) -> ours (joints first), as Kinematics.frames_into's np.take
        n = Jw.shape[2]
        l = n - 6
        for f in range(Jw.shape[0]):
            for r in range(6):
                for c in range(l):
                    Jw[f, r, c] = Jraw[f, r, 6 + c]
                for c in range(6):
                    Jw[f, r, l + c] = Jraw[f, r, c]
    run_rows(ids, params, frames, row0, dims, selected, P, Jw, q, eta, wRv, env, X, J, A, XD, E, status)
    slots, level_of, inequality, level_rows, slot_row, level_lams, level_ths = layout_views(lay_i, lay_f)
    SJ, Sa, Sx, lams, ths, raw, applied, factors, offsets, level_ids = stack_views(stack_i, stack_f)
    return gather_solve(
        slots,
        level_of,
        inequality,
        status,
        row0,
        dims,
        A,
        J,
        XD,
        v_top,
        SJ,
        Sa,
        Sx,
        level_rows,
        slot_row,
        level_lams,
        level_ths,
        level_ids,
        offsets,
        lams,
        ths,
        lam_mv,
        th_mv,
        eta_w,
        limits,
        raw,
        applied,
        factors,
        out,
    )
