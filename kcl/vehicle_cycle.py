"""TPIK 1's steady cycle, from the measurement to the clipped vehicle reference,
in ONE compiled call (:func:`vehicle_cycle`).

The vehicle step (:meth:`kcl.controller.UvmsController.vehicle_step`, ~10 Hz)
solves the whole hierarchy over all ``n = l + 6`` columns: on top (when some
vehicle DOFs are not actuated) the measured-velocity task pinning those DOFs to
the fed velocity, then every level of the current action. In the steady plan
(every task of the action with a row kernel, no transition running) that is a
fixed sequence, which :func:`vehicle_cycle` runs in one call, the same
operations in the same order as the step by step path: the input check
(:func:`kcl.cycle.finite_total`), the kinematics set-up
(:func:`kcl.kin_kernel.configure`), the frames (:func:`kcl.kin_frames.frames_world`),
the task kernels (:func:`kcl.tasks.batch.run_rows`), the top level's rows (as
:class:`kcl.tasks.MeasuredVehicleVelocity` gives them), the copy of the task
rows (:func:`kcl.tasks.batch.gather_rows`), the levels closed in order, the
check (:func:`kcl.icat_kernel.check_stack`), the solve with the joint and
vehicle velocity limits (:func:`kcl.icat_kernel.solve`), the finiteness test
and the vehicle part of the solution with its non-actuated DOFs zeroed and
clipped to the vehicle limits. :mod:`kcl.controller_vehicle` is the Python side.

Numba's cache of :func:`vehicle_cycle` embeds the functions it calls (other
files): :func:`kcl.jit_cache.drop_stale` discards it when one of them is newer.
"""

from __future__ import annotations

from kcl import arm_cycle as _arm_cycle
from kcl import cycle as _cycle
from kcl import icat_kernel, kin_frames, kin_kernel, small_linalg
from kcl.arm_cycle import INPUTS_NOT_FINITE, layout_views, stack_views
from kcl.cycle import BAD_INPUT, NOT_FINITE, SOLVED, check_and_solve, close_levels, inputs_finite
from kcl.jit_cache import drop_stale
from kcl.kin_frames import frames_world
from kcl.kin_kernel import configure
from kcl.tasks import batch as _batch
from kcl.tasks.batch import batch_views, gather_rows, run_rows
from kcl.tasks.jit import ENV_VELOCITY, SHARED_SOURCES, njit

drop_stale(
    __file__,
    [
        __file__,
        _arm_cycle.__file__,
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

#: ``level_ids`` entry of the top level (the measured-velocity task) in the stack
TOP_LEVEL = -2

__all__ = ["INPUTS_NOT_FINITE", "TOP_LEVEL", "vehicle_cycle", "SOLVED", "BAD_INPUT", "NOT_FINITE"]


@njit
def vehicle_cycle(
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
    a_top,
    top,
    lam_top,
    th_top,
    lam_mv,
    th_mv,
    eta_w,
    limits,
    vlim,
    actuated,
    kin_i,
    kin_f,
    qff,
    v_meas,
    t_meas,
    altitude,
    out,
):
    """TPIK 1 at the measured state (see the module docstring).

    ``q`` (l,) rad, ``eta`` (6,) world NED pose, ``v_meas`` (6,) the measured
    velocity (zeros without one: it only enters the input check), ``t_meas`` (s),
    ``altitude`` (m, 0 without one) are checked for finiteness (returns
    :data:`INPUTS_NOT_FINITE` at once, nothing changed but the scratch ``wRv``);
    ``v_top`` (6,) the velocity fed to the TPIK (top task and velocity tasks);
    ``top``: put the measured-velocity level first, with activation ``a_top``
    (1 on the non-actuated DOFs) and regularization ``lam_top`` / ``th_top``;
    ``limits`` (n,) the joint and vehicle velocity limits of the solve; ``vlim``
    (6,) the clip of the result; ``actuated`` (6,) 0/1; ``out`` (6,) the vehicle
    body velocity reference.

    Returns ``(status, levels, rows, changed, bad_level, bad_code)`` as
    :func:`kcl.cycle.gather_solve`; ``level_ids`` holds :data:`TOP_LEVEL` for the
    top level and the hierarchy level of the others."""
    if not inputs_finite(q, eta, v_meas, t_meas, altitude):
        return INPUTS_NOT_FINITE, 0, 0, False, -1, 0
    configure(q, eta, wRv, qff)
    ids, frames, row0, dims, status, X, J, A, XD, E, P, Jw, Jraw, env, params = batch_views(batch_i, batch_f)
    frames_world(q, eta, wRv, kin_i, kin_f, P, Jw)
    for i in range(6):
        env[ENV_VELOCITY + i] = v_top[i]
    run_rows(ids, params, frames, row0, dims, selected, P, Jw, q, eta, wRv, env, X, J, A, XD, E, status)
    slots, level_of, inequality, level_rows, slot_row, level_lams, level_ths = layout_views(lay_i, lay_f)
    SJ, Sa, Sx, lams, ths, raw, applied, factors, offsets, level_ids = stack_views(stack_i, stack_f)
    n = SJ.shape[1]
    l = n - 6
    start = 0
    count = 0
    changed = False
    if top:  # the measured-velocity task: J = [0 I_6], reference the fed velocity
        for i in range(6):
            for c in range(n):
                SJ[i, c] = 0.0
            SJ[i, l + i] = 1.0
            Sa[i] = a_top[i]
            Sx[i] = v_top[i]
        start = 6
        lams[0] = lam_top
        ths[0] = th_top
        offsets[1] = 6
        if level_ids[0] != TOP_LEVEL:
            level_ids[0] = TOP_LEVEL
            changed = True
        count = 1
    for i in range(level_rows.shape[0]):
        level_rows[i] = 0
    rows = gather_rows(
        slots, level_of, inequality, status, row0, dims, A, J, XD, False, v_top, SJ, Sa, Sx, start, level_rows, slot_row
    )
    count, changed = close_levels(level_rows, level_lams, level_ths, lams, ths, offsets, level_ids, count, changed)
    if count == 0:  # nothing active: the minimum-velocity solution is zero
        for i in range(6):
            out[i] = 0.0
        return SOLVED, count, rows, changed, -1, 0
    code, rho, bad, bad_code = check_and_solve(
        SJ, Sa, Sx, offsets, lams, ths, count, lam_mv, th_mv, eta_w, limits, raw, applied, factors
    )
    if code != SOLVED:
        return code, count, rows, changed, bad, bad_code
    for i in range(6):
        v = rho[l + i] if actuated[i] else 0.0
        v = min(v, vlim[i])
        out[i] = max(v, -vlim[i])
    return SOLVED, count, rows, changed, -1, 0
