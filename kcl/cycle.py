"""TPIK 2's steady cycle in one compiled call: stack the rows, close the levels,
validate, solve, clip (used by :meth:`kcl.stacking.StackingMixin._fill_compiled`);
and the controller's per-step input test (:func:`finite_total`).

:func:`gather_solve` runs, in one Numba call, exactly what the controller
otherwise does in four calls with Python in between:
:func:`kcl.tasks.batch.gather_rows` (arm-only rows into the stack),
:meth:`kcl.icat_stacked.StackedLevels.close_level` for each level that got rows,
:func:`kcl.icat_kernel.check_stack`, :func:`kcl.icat_kernel.solve` (with the
minimum-velocity level and the joint limits), the finiteness check of the
solution and the clip into the limits (``min(max(...))``, as the controller's
``np.minimum`` / ``np.maximum``). Same operations in the same order: the same
numbers, bit for bit.

Numba's cache of :func:`gather_solve` embeds the functions it calls (other
files): :func:`kcl.jit_cache.drop_stale` discards it when one of them is newer.
"""

from __future__ import annotations

import math

from kcl import icat_kernel, small_linalg
from kcl.icat_kernel import check_stack, solve
from kcl.jit_cache import drop_stale
from kcl.tasks import batch as _batch
from kcl.tasks.batch import gather_rows
from kcl.tasks.jit import njit

drop_stale(__file__, [__file__, _batch.__file__, icat_kernel.__file__, small_linalg.__file__])

#: :func:`gather_solve` status codes
SOLVED = 0
BAD_INPUT = 1  # a level's rows failed check_stack: (level, code) returned
NOT_FINITE = 2  # the solver returned a non-finite velocity


@njit
def gather_solve(
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
    eta,
    limits,
    raw,
    applied,
    factors,
    out,
):
    """TPIK 2 from the task batch rows to the clipped joint velocities ``out`` (l,).

    Rows: as :func:`gather_rows` with ``arm_only`` from stack row 0 (``SJ``,
    ``Sa``, ``Sx``; per-level counts into ``level_rows``, zeroed first). Levels:
    hierarchy level ``li`` with rows becomes the next stack level, with
    ``level_lams[li]`` / ``level_ths[li]`` (``offsets``, ``lams``, ``ths``;
    ``level_ids[k] = li``). Then check, solve (minimum-velocity level
    ``lam_mv`` / ``th_mv``, weight ``eta``, per-joint ``limits``), clip.

    Returns ``(status, levels, rows, changed, bad_level, bad_code)``: status
    :data:`SOLVED` (``out`` written; zeros when no level has rows),
    :data:`BAD_INPUT` (stack level ``bad_level`` failed :func:`check_stack`
    with ``bad_code``) or :data:`NOT_FINITE`; ``changed``: the level layout
    (``level_ids`` of the levels) differs from the one these arrays held.
    """
    for i in range(level_rows.shape[0]):
        level_rows[i] = 0
    rows = gather_rows(
        slots, level_of, inequality, status, row0, dims, A, J, XD, True, v_top, SJ, Sa, Sx, 0, level_rows, slot_row
    )
    count, changed = close_levels(level_rows, level_lams, level_ths, lams, ths, offsets, level_ids, 0, False)
    n = out.shape[0]
    if count == 0:  # nothing active: the minimum-velocity solution is zero
        for i in range(n):
            out[i] = 0.0
        return SOLVED, count, rows, changed, -1, 0
    code, rho, bad, bad_code = check_and_solve(
        SJ, Sa, Sx, offsets, lams, ths, count, lam_mv, th_mv, eta, limits, raw, applied, factors
    )
    if code != SOLVED:
        return code, count, rows, changed, bad, bad_code
    for i in range(n):
        v = min(rho[i], limits[i])
        out[i] = max(v, -limits[i])
    return SOLVED, count, rows, changed, -1, 0


@njit
def close_levels(level_rows, level_lams, level_ths, lams, ths, offsets, level_ids, count, changed):
    """Close the stack levels of the hierarchy levels that got rows (``level_rows[li]``,
    in order) after the ``count`` levels already closed: their regularization
    (``level_lams`` / ``level_ths``) into ``lams`` / ``ths``, their row ranges into
    ``offsets``, ``level_ids[k] = li`` (then -1 after the last). Returns the new
    ``(count, changed)``: ``changed`` also when the level layout differs from the one
    these arrays held."""
    for li in range(level_rows.shape[0]):
        r = level_rows[li]
        if r:
            lams[count] = level_lams[li]
            ths[count] = level_ths[li]
            offsets[count + 1] = offsets[count] + r
            if level_ids[count] != li:
                level_ids[count] = li
                changed = True
            count += 1
    if level_ids[count] != -1:  # the previous layout had more levels
        level_ids[count] = -1
        changed = True
    return count, changed


@njit
def check_and_solve(SJ, Sa, Sx, offsets, lams, ths, count, lam_mv, th_mv, eta, limits, raw, applied, factors):
    """:func:`kcl.icat_kernel.check_stack`, then :func:`kcl.icat_kernel.solve` (with the
    minimum-velocity level and the limits) of the ``count`` closed levels, then the
    finiteness of the solution. Returns ``(status, solution, bad_level, bad_code)``:
    :data:`SOLVED`, :data:`BAD_INPUT` (level ``bad_level`` failed with ``bad_code``)
    or :data:`NOT_FINITE`."""
    bad, code = check_stack(SJ, Sa, Sx, offsets[: count + 1])
    if bad >= 0:
        return BAD_INPUT, SJ[0], bad, code
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
        eta,
        limits,
        True,
        raw,
        applied,
        factors,
    )
    for i in range(rho.shape[0]):
        if not math.isfinite(rho[i]):
            return NOT_FINITE, rho, -1, 0
    return SOLVED, rho, -1, 0


@njit
def finite_total(q, eta, v, t, altitude):
    """Whether ``sum(q^2) + sum(eta^2) + sum(v^2) + t + altitude`` is finite: the
    controller's fast test that every input is finite (False also when the sum
    overflows; the controller then checks each input on its own). Called from
    Python (its dispatcher is locked after the warm-up: :func:`no_compile`); the
    compiled cycles call :func:`inputs_finite`, the same test."""
    return inputs_finite(q, eta, v, t, altitude)


@njit
def inputs_finite(q, eta, v, t, altitude):
    """:func:`finite_total`, for compiled callers."""
    total = 0.0
    for x in q:
        total += x * x
    for x in eta:
        total += x * x
    for x in v:
        total += x * x
    return math.isfinite(total + t + altitude)


def no_compile(fn: object) -> None:
    """Forbid further Numba compilations of ``fn`` (a loaded dispatcher): a call
    with other argument types (read-only or strided arrays) then raises TypeError,
    which the caller answers with its numpy path, instead of compiling for seconds
    inside a control cycle. No effect without Numba."""
    disable = getattr(fn, "disable_compile", None)
    if disable is not None:
        disable()
