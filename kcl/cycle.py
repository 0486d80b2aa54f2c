"""One TPIK of the controller, from the measurement to the clipped reference, in
ONE compiled call per step (:func:`tpik_cycle`).

The controller solves two TPIKs (MARIS III-B9): TPIK 1 at the vehicle rate over
all ``n = l + 6`` columns (the vehicle reference) and TPIK 2 at the arm rate over
the ``l`` joint columns (the joint references, the measured vehicle velocity
moved to the right-hand side). Each is a :class:`TpikProblem`: its
:class:`StackPlan` (which tasks of the hierarchy it stacks, in which levels, with
which regularization; what it returns) and its preallocated stack and output.
The per-step data are arrays: the measurement, the velocity fed to the top task,
the action-transition factor of each task (``StackPlan.factors``, written by the
controller from :class:`kcl.blend.ActionBlend`).

One call of :func:`tpik_cycle` runs, in order: the input check (every input
finite, else nothing changes); the low-pass step of the measured vehicle velocity
(:mod:`kcl.filters`); the vehicle rotation (:func:`kcl.kin_kernel.configure`); the
frames the tasks read (:func:`kcl.kin_frames.frames_world`, once per state); the
row kernels of the tasks with a factor > 0 (once per state, velocity tasks at
every call: they read the fed velocity); their records for telemetry; the stack:
TPIK 1's top level (the measured-velocity task ``J = [0 I_6]`` on the vehicle DOFs
that are not actuated, MARIS III-B8), then each task's rows with its activation
times its factor, a task idle or (inequality) with every row inactive left out,
TPIK 2's rows as ``J_q`` and ``xdot - J_v v`` (the measured-velocity task on all
six DOFs solved exactly: the vehicle columns are known); the levels closed in
hierarchy order; the check of the stacked data; the solve with the final
minimum-velocity level (:func:`kcl.icat_kernel.solve`); the finiteness of the
result; the output, non-actuated DOFs zeroed, clipped into the limits.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from kcl import filters, icat_kernel, kin_frames, kin_kernel
from kcl.buffers import take, take2
from kcl.icat import CHECK_MESSAGES
from kcl.icat_kernel import check_stack, solve
from kcl.jit import drop_stale, njit
from kcl.kin_frames import frames_world
from kcl.kin_kernel import configure
from kcl.tasks import batch as _batch
from kcl.tasks.batch import TaskBatch, batch_views, run_task
from kcl.tasks.jit import ENV_ALTITUDE, ENV_HAS_ALTITUDE, ENV_VELOCITY

drop_stale(
    __file__,
    [filters.__file__, _batch.__file__, icat_kernel.__file__, kin_frames.__file__, kin_kernel.__file__]
    + _batch.KERNEL_SOURCES,
)

# status codes of tpik_cycle
SOLVED = 0
INPUTS_NOT_FINITE = 1
BAD_TASK_DATA = 2  # a level's rows failed check_stack: (level, code) returned
NOT_FINITE = 3  # the solver returned a non-finite velocity

#: level id of TPIK 1's top level (the measured-velocity task) in the stack
TOP_LEVEL = -2

_VELOCITY_KIND = 2


@njit
def inputs_finite(q: np.ndarray, eta: np.ndarray, v: np.ndarray, t: float, altitude: float) -> bool:
    """Whether every entry of ``q``, ``eta``, ``v`` and the scalars ``t``,
    ``altitude`` is finite: a sum of squares is finite iff every entry is, or it
    overflowed (then the caller's detailed check finds nothing wrong)."""
    total = 0.0
    for x in q:
        total += x * x
    for x in eta:
        total += x * x
    for x in v:
        total += x * x
    return math.isfinite(total + t + altitude)


@njit
def plan_views(ibuf: np.ndarray, fbuf: np.ndarray) -> tuple[Any, ...]:
    """The arrays of a :class:`StackPlan`: ``(arm_only, top, slots, level_of,
    inequality, level_rows, slot_row, regularization, lams, ths, factors, a_top,
    actuated, limits, clip)``; ``ibuf[:6]`` = (slots, levels, arm_only, top, limits,
    outputs); ``regularization`` = (lam, threshold, eta)."""
    s, nl, arm_only, top, nlim, nout = ibuf[0], ibuf[1], ibuf[2], ibuf[3], ibuf[4], ibuf[5]
    slots, o = take(ibuf, 6, s)
    level_of, o = take(ibuf, o, s)
    inequality, o = take(ibuf, o, s)
    level_rows, o = take(ibuf, o, nl)
    slot_row, o = take(ibuf, o, s)
    regularization, o = take(fbuf, 0, 3)
    lams, o = take(fbuf, o, nl)
    ths, o = take(fbuf, o, nl)
    factors, o = take(fbuf, o, s)
    a_top, o = take(fbuf, o, 6)
    actuated, o = take(fbuf, o, nout)
    limits, o = take(fbuf, o, nlim)
    clip, o = take(fbuf, o, nout)
    return (
        arm_only != 0,
        top != 0,
        slots,
        level_of,
        inequality,
        level_rows,
        slot_row,
        regularization,
        lams,
        ths,
        factors,
        a_top,
        actuated,
        limits,
        clip,
    )


@njit
def stack_views(ibuf: np.ndarray, fbuf: np.ndarray) -> tuple[np.ndarray, ...]:
    """The arrays of a :class:`Stack`: ``(J, a, xdot, lams, ths, raw, applied,
    factors, offsets, level_ids, out, wRv, qff)``; ``ibuf[:5]`` = (rows, columns,
    levels, outputs, joints)."""
    rows, ncols, max_levels, nout, l = ibuf[0], ibuf[1], ibuf[2], ibuf[3], ibuf[4]
    J, o = take2(fbuf, 0, rows, ncols)
    a, o = take(fbuf, o, rows)
    xdot, o = take(fbuf, o, rows)
    lams, o = take(fbuf, o, max_levels)
    ths, o = take(fbuf, o, max_levels)
    raw, o = take2(fbuf, o, max_levels + 1, ncols)
    applied, o = take2(fbuf, o, max_levels + 1, ncols)
    factors, o = take(fbuf, o, max_levels + 1)
    out, o = take(fbuf, o, nout)
    wRv, o = take2(fbuf, o, 3, 3)
    qff, o = take(fbuf, o, 7 + l)
    offsets, o = take(ibuf, 5, max_levels + 1)
    level_ids, o = take(ibuf, o, max_levels + 1)
    return J, a, xdot, lams, ths, raw, applied, factors, offsets, level_ids, out, wRv, qff


@njit
def tpik_cycle(
    batch_i: np.ndarray,
    batch_f: np.ndarray,
    plan_i: np.ndarray,
    plan_f: np.ndarray,
    stack_i: np.ndarray,
    stack_f: np.ndarray,
    chain_i: np.ndarray,
    chain_f: np.ndarray,
    q: np.ndarray,
    eta: np.ndarray,
    v_meas: np.ndarray,
    v_top: np.ndarray,
    filt: np.ndarray,
    t: float,
    t_meas: float,
    altitude: float,
    has_altitude: bool,
    filter_gain: float,
    filter_mode: int,
    state_id: int,
    work: bool,
) -> tuple[int, int, int, int]:
    """One TPIK step (see the module docstring).

    ``q`` (l,) rad, ``eta`` (6,) world NED pose, ``v_meas`` (6,) the measured body
    velocity (zeros without one), ``t_meas`` (s) and ``altitude`` (m, used when
    ``has_altitude``) are checked first. ``filt`` (6,): the low-pass state, set to
    ``v_meas`` (``filter_mode`` :data:`kcl.filters.START`) or stepped towards it
    with gain ``filter_gain`` (:data:`kcl.filters.STEP`). ``v_top`` (6,): the velocity fed to the top task
    and the velocity tasks (it may be ``filt`` itself). ``state_id``: the caller's
    number of this state (q, eta, altitude, targets): task rows and frames computed
    at the same number are reused. ``work`` False: stop after the filter step. ``t``
    (s): the time of the records.

    Returns ``(status, levels, bad_level, bad_code)``: :data:`SOLVED` (the plan's
    output written), :data:`INPUTS_NOT_FINITE` (nothing changed),
    :data:`BAD_TASK_DATA` (stack level ``bad_level`` failed
    :func:`kcl.icat_kernel.check_stack` with ``bad_code``) or :data:`NOT_FINITE`.
    """
    if not inputs_finite(q, eta, v_meas, t_meas, altitude if has_altitude else 0.0):
        return INPUTS_NOT_FINITE, 0, -1, 0
    if filter_mode == filters.START:
        for i in range(6):
            filt[i] = v_meas[i]
    elif filter_mode == filters.STEP:
        filters.lowpass_step(filt, v_meas, filter_gain)
    if not work:
        return SOLVED, 0, -1, 0
    kernel, kind, frames, row0, dims, status, stamp, X, J, A, XD, E, P, Jw, env, params, t_rec, ap_rec = batch_views(
        batch_i, batch_f
    )
    (
        arm_only,
        top,
        slots,
        level_of,
        inequality,
        level_rows,
        slot_row,
        regularization,
        level_lams,
        level_ths,
        factors,
        a_top,
        actuated,
        limits,
        clip,
    ) = plan_views(plan_i, plan_f)
    lam_mv, th_mv, eta_w = regularization[0], regularization[1], regularization[2]
    SJ, Sa, Sx, lams, ths, raw, applied, sfactors, offsets, level_ids, out, wRv, qff = stack_views(stack_i, stack_f)
    configure(q, eta, wRv, qff)
    if batch_i[_batch.FRAMES_STATE] != state_id:
        frames_world(q, eta, wRv, chain_i, chain_f, P, Jw)
        batch_i[_batch.FRAMES_STATE] = state_id
    env[ENV_HAS_ALTITUDE] = 1.0 if has_altitude else 0.0
    env[ENV_ALTITUDE] = altitude if has_altitude else 0.0
    for i in range(6):
        env[ENV_VELOCITY + i] = v_top[i]
    # the task rows: each task with a factor > 0, once per state (velocity tasks every call)
    for i in range(slots.shape[0]):
        if factors[i] <= 0.0:
            continue
        k = slots[i]
        t_rec[k] = t
        ap_rec[k] = factors[i]
        if kind[k] != _VELOCITY_KIND and stamp[k] == state_id:
            continue
        r0 = row0[k]
        r1 = r0 + dims[k]
        X[r0:r1] = 0.0
        J[r0:r1] = 0.0
        A[r0:r1] = 0.0
        XD[r0:r1] = 0.0
        E[r0:r1] = 0.0
        s = run_task(
            kernel[k], params[k], frames[k], P, Jw, q, eta, wRv, env, X[r0:r1], J[r0:r1], A[r0:r1], XD[r0:r1], E[r0:r1]
        )
        if s != 0:  # idle: rows back to zero
            X[r0:r1] = 0.0
            J[r0:r1] = 0.0
            A[r0:r1] = 0.0
            XD[r0:r1] = 0.0
            E[r0:r1] = 0.0
        status[k] = s
        stamp[k] = state_id
    # the stack
    ncols = SJ.shape[1]
    l = ncols if arm_only else ncols - 6
    p = 0
    count = 0
    if top:
        for i in range(6):
            for c in range(ncols):
                SJ[i, c] = 0.0
            SJ[i, l + i] = 1.0
            Sa[i] = a_top[i]
            Sx[i] = v_top[i]
        p = 6
        lams[0] = lam_mv
        ths[0] = th_mv
        offsets[0] = 0
        offsets[1] = 6
        level_ids[0] = TOP_LEVEL
        count = 1
    for li in range(level_rows.shape[0]):
        level_rows[li] = 0
    for i in range(slots.shape[0]):
        slot_row[i] = -1
        f = factors[i]
        k = slots[i]
        if f <= 0.0 or status[k] != 0:
            continue
        r0 = row0[k]
        m = dims[k]
        if inequality[i]:
            active = False
            for r in range(r0, r0 + m):
                if A[r] != 0.0:  # (NaN counts as active: the check refuses it)
                    active = True
            if not active:
                continue
        slot_row[i] = p
        for r in range(m):
            Sa[p + r] = A[r0 + r] * f if f < 1.0 else A[r0 + r]
            if arm_only:
                for c in range(l):
                    SJ[p + r, c] = J[r0 + r, c]
                acc = 0.0
                for c in range(6):
                    acc += J[r0 + r, l + c] * v_top[c]
                Sx[p + r] = XD[r0 + r] - acc
            else:
                for c in range(ncols):
                    SJ[p + r, c] = J[r0 + r, c]
                Sx[p + r] = XD[r0 + r]
        level_rows[level_of[i]] += m
        p += m
    offsets[0] = 0
    for li in range(level_rows.shape[0]):
        r = level_rows[li]
        if r:
            lams[count] = level_lams[li]
            ths[count] = level_ths[li]
            offsets[count + 1] = offsets[count] + r
            level_ids[count] = li
            count += 1
    level_ids[count] = -1
    nout = out.shape[0]
    if count == 0:  # nothing active: the minimum-velocity solution is zero
        for i in range(nout):
            out[i] = 0.0
        return SOLVED, 0, -1, 0
    bad, code = check_stack(SJ, Sa, Sx, offsets[: count + 1])
    if bad >= 0:
        return BAD_TASK_DATA, count, bad, code
    rho, _final = solve(
        SJ,
        Sa,
        Sx,
        offsets[: count + 1],
        lams[:count],
        ths[:count],
        True,
        lam_mv,
        th_mv,
        eta_w,
        limits,
        True,
        raw,
        applied,
        sfactors,
    )
    for i in range(rho.shape[0]):
        if not math.isfinite(rho[i]):
            return NOT_FINITE, count, -1, 0
    first = 0 if arm_only else l
    for i in range(nout):
        v = rho[first + i] if actuated[i] != 0.0 else 0.0
        v = min(v, clip[i])
        out[i] = max(v, -clip[i])
    return SOLVED, count, -1, 0


@dataclass(frozen=True)
class PlanLevel:
    """One level of the hierarchy as a TPIK stacks it: its name and regularization."""

    name: str
    lam: float
    threshold: float


@dataclass
class StackPlan:
    """What one TPIK stacks and returns (the data :func:`tpik_cycle` reads).

    ``slots``: batch slots of the tasks it may stack, hierarchy order;
    ``task_index``: their position in the hierarchy (``ActionBlend`` factors);
    ``level_of``: their level; ``inequality``: whether all-inactive rows leave them
    out; ``factors``: their action-transition factor this step. ``arm_only``: TPIK 2
    (joint columns, the vehicle velocity on the right-hand side), else TPIK 1 (all
    columns) with, when ``top``, the measured-velocity level first, activation
    ``a_top`` (1 on the non-actuated DOFs). ``limits``: the saturation of the
    solve (per column); ``actuated`` / ``clip``: per output row, whether it is
    kept (1) or zeroed (0), and its clip (rad/s for the joints, m/s and rad/s for the vehicle)."""

    slots: np.ndarray
    task_index: np.ndarray
    level_of: np.ndarray
    inequality: np.ndarray
    levels: tuple[PlanLevel, ...]
    arm_only: bool
    top: bool
    a_top: np.ndarray
    actuated: np.ndarray
    limits: np.ndarray
    clip: np.ndarray
    lam: float
    threshold: float
    eta: float
    ibuf: np.ndarray = field(init=False, repr=False)
    fbuf: np.ndarray = field(init=False, repr=False)
    factors: np.ndarray = field(init=False, repr=False)

    def __post_init__(self) -> None:
        s, nl = self.slots.shape[0], len(self.levels)
        nlim, nout = self.limits.shape[0], self.clip.shape[0]
        self.ibuf = np.zeros(6 + 4 * s + nl, dtype=np.int64)
        self.ibuf[:6] = (s, nl, int(self.arm_only), int(self.top), nlim, nout)
        self.fbuf = np.zeros(3 + 2 * nl + s + 6 + 2 * nout + nlim)
        (_, _, slots, level_of, inequality, _, _, reg, lams, ths, self.factors, a_top, actuated, limits, clip) = (
            plan_views(self.ibuf, self.fbuf)
        )
        reg[:] = (self.lam, self.threshold, self.eta)
        slots[:] = self.slots
        level_of[:] = self.level_of
        inequality[:] = self.inequality
        lams[:] = [lv.lam for lv in self.levels]
        ths[:] = [lv.threshold for lv in self.levels]
        a_top[:] = self.a_top
        actuated[:] = self.actuated
        limits[:] = self.limits
        clip[:] = self.clip

    @property
    def rows(self) -> int:
        """Number of output rows: l (TPIK 2) or 6 (TPIK 1)."""
        return int(self.clip.shape[0])


class Stack:
    """The preallocated stack of one TPIK (rows x ncols), its per-level arrays, the
    output and the step's scratch, as views of one float64 and one int64 buffer."""

    def __init__(self, max_rows: int, ncols: int, max_levels: int, nout: int, l: int):
        rows = max(1, max_rows)
        size = rows * (ncols + 2) + 2 * max_levels + (max_levels + 1) * (2 * ncols + 1) + nout + 9 + 7 + l
        self.fbuf = np.zeros(size)
        self.ibuf = np.zeros(5 + 2 * (max_levels + 1), dtype=np.int64)
        self.ibuf[:5] = (rows, ncols, max_levels, nout, l)
        (self.J, self.a, self.xdot, self.lams, self.ths, _, _, _, self.offsets, self.level_ids, self.out, _, _) = (
            stack_views(self.ibuf, self.fbuf)
        )
        self.level_ids[:] = -1

    def level_names(self, count: int, plan: StackPlan, top_name: str) -> list[str]:
        """Names of the first ``count`` stack levels of the last step."""
        return [top_name if li == TOP_LEVEL else plan.levels[li].name for li in self.level_ids[:count].tolist()]


class TpikProblem:
    """One TPIK of the controller: its :class:`StackPlan`, its :class:`Stack`, the
    task batch and kinematic chain it shares with the other TPIK, and the call of
    :func:`tpik_cycle`."""

    def __init__(
        self,
        plan: StackPlan,
        batch: TaskBatch,
        chain: tuple[np.ndarray, np.ndarray],
        *,
        l: int,
        top_name: str,
    ):
        self.plan = plan
        self.batch = batch
        self.chain_i, self.chain_f = chain
        ncols = l if plan.arm_only else l + 6
        rows = int(sum(batch.dims[plan.slots].tolist())) + (6 if plan.top else 0)
        self.stack = Stack(rows, ncols, len(plan.levels) + 1, plan.rows, l)
        #: the output of the last solved step (a view: copy it)
        self.out = self.stack.out
        self.top_name = top_name
        self.levels = 0
        self._bad_level = -1
        self._bad_code = 0

    def run(
        self,
        q: np.ndarray,
        eta: np.ndarray,
        v_meas: np.ndarray,
        v_top: np.ndarray,
        filt: np.ndarray,
        t: float,
        t_meas: float,
        altitude: float | None,
        filter_mode: int,
        filter_gain: float,
        state_id: int,
        work: bool,
    ) -> int:
        """:func:`tpik_cycle` on this problem (arguments as documented there;
        ``altitude`` None: unknown). Returns its status; :meth:`fault_reason`
        explains a failed solve."""
        batch, plan, stack = self.batch, self.plan, self.stack
        status, self.levels, self._bad_level, self._bad_code = tpik_cycle(
            batch.ibuf,
            batch.fbuf,
            plan.ibuf,
            plan.fbuf,
            stack.ibuf,
            stack.fbuf,
            self.chain_i,
            self.chain_f,
            q,
            eta,
            v_meas,
            v_top,
            filt,
            float(t),
            float(t_meas),
            0.0 if altitude is None else float(altitude),
            altitude is not None,
            float(filter_gain),
            int(filter_mode),
            int(state_id),
            bool(work),
        )
        return int(status)

    def fault_reason(self, status: int) -> str:
        """The controller's fault message for a failed solve's ``status``."""
        if status == BAD_TASK_DATA:
            name = self.stack.level_names(self.levels, self.plan, self.top_name)[self._bad_level]
            return f"solver refused the task data: level {self._bad_level} ({name}): {CHECK_MESSAGES[self._bad_code]}"
        return "solver returned a non-finite velocity"
