"""Stacking the active tasks into the two TPIK problems (part of the controller).

:class:`StackingMixin` is the half of :class:`kcl.controller.UvmsController` that
turns the current plan (levels of tasks, with their action-transition factors
a_p) into the rows of the preallocated :class:`kcl.icat_stacked.StackedLevels` of TPIK 1
(all ``n = l + 6`` columns) and TPIK 2 (the ``l`` joint columns, the measured
vehicle velocity moved to the right-hand side). It is kept apart because it is
the speed-critical bookkeeping of the controller: compiled task batches
(:class:`kcl.tasks.batch.TaskBatch`), the steady-state compiled copy
(:func:`kcl.tasks.batch.gather_rows`), the usual arm step in one compiled call
(:meth:`StackingMixin._arm_fast`, :func:`kcl.arm_cycle.arm_cycle`) and the
TPIK 1 -> TPIK 2 row reuse.

It reads the controller's state (``_plan``, ``_full_plan``, ``_records``,
``_cache_out``, ``_batch``, ``_steady_batch``, ``_level_memos``, ``_stack1``/``_stack2``,
``_arm_rows``, ``_arm_levels``, ``_one_block``, ``_ap``, ``_t_switch``, ``actions``, ``_l``,
``_no_velocity``, ``_evaluate``); only the controller uses it.
"""

from __future__ import annotations

import numpy as np

from kcl.arm_cycle import FRAMES_COMPUTE, FRAMES_READY, FRAMES_REORDER, arm_cycle, layout_buffers
from kcl.cycle import BAD_INPUT, SOLVED, gather_solve, no_compile
from kcl.icat import _label
from kcl.icat_stacked import CHECK_MESSAGES, StackedLevels
from kcl.tasks import Task, TaskContext
from kcl.tasks.batch import copy_arm_rows, gather_rows
from kcl.vehicle_cycle import vehicle_cycle

#: :meth:`StackingMixin._fill`'s result when it only stacked (the caller solves)
UNSOLVED = object()


class StackingMixin:
    #: identity of the current ``_arm_rows`` / ``_arm_levels`` content (new object when rewritten)
    _arm_token: object | None = None

    #: (arm token, count, rows used) of the last :meth:`_derive_arm_stack` levels
    _derive_memo: tuple | None = None
    #: the steady selection ``_batch.selected`` holds (None: another one)
    _selection_set: object | None = None
    # and, per instance, ``_level_memos``: arm_only -> the last level layout
    # written by :meth:`_fill_compiled` (layout, start, arm token, slot rows,
    # count, rows used); see :attr:`kcl.icat_stacked.StackedLevels.token`

    def _fill(
        self,
        stack: StackedLevels,
        ctx: TaskContext,
        t: float,
        arm_only: bool,
        v_top: np.ndarray | None = None,
        limits: np.ndarray | None = None,
    ) -> object:
        """Append the active levels of the hierarchy, a_p applied, to ``stack``.

        Returns :data:`UNSOLVED`, or, when ``limits`` (TPIK 2's joint limits) is
        given and the steady compiled path applies, the already solved and
        clipped joint velocities (None after a fault): see :meth:`_fill_compiled`.

        arm_only (TPIK 2): the top task pins the six vehicle DOFs to ``v_top``;
        that is solved exactly by moving the known vehicle motion to the right-hand
        side (``xdot - J_v v_top``) and solving for the l joint velocities only
        (same result as the full n-column stack: Q after the top level is
        diag(I_l, 0); checked in tests), with vehicle-only tasks left out.
        """
        records = self._records
        steady = t - self._t_switch >= self.actions.transition_time
        layout = self._run_batch(ctx, t, arm_only, steady)
        if layout is not None:
            return self._fill_compiled(stack, layout, t, arm_only, v_top, limits)
        arm_rows = self._arm_rows  # (TPIK 1) rows of the arm-using tasks, per level
        arm_levels = self._arm_levels
        if not arm_only:
            arm_rows.clear()
            arm_levels.clear()
            self._arm_token = object()
        # gather the stacked tasks' arrays, copy them in with a few large numpy
        # calls at the end (cheaper than per-task slice assignments)
        Js: list[np.ndarray] = []
        As: list[np.ndarray] = []
        Xs: list[np.ndarray] = []
        cache = self._cache_out
        start = p = stack.rows_used
        for tasks, lam, threshold, name in self._plan if steady else self._full_plan:
            p0 = p
            n_arm = arm_rows.count
            for task in tasks:
                ap = 1.0 if steady else self._ap(task.name, t)
                if ap <= 0.0:
                    continue
                if arm_only and not task.USES_ARM:
                    continue  # it cannot act once the vehicle DOFs are pinned
                out = cache.get(task.name) if task.KIND != "velocity" else None
                if out is None:
                    out = self._evaluate(task, ctx)
                a = out.a * ap if ap < 1.0 else out.a
                records[task.name] = (t, a, out)
                if out.note or (task.KIND == "inequality" and not any(a.tolist())):
                    continue  # idle, or every row inactive: the level would be skipped anyway
                Js.append(out.J)
                As.append(a)
                Xs.append(out.xdot)
                q = p + a.shape[0]
                if task.USES_ARM and not arm_only:
                    arm_rows.add(p, q)
                p = q
            if p > p0:
                stack.close_level(p - p0, lam, threshold, name)
                if arm_rows.count > n_arm:
                    arm_levels.append((arm_rows.count - n_arm, lam, threshold, name))
        if p == start:
            return UNSOLVED
        J = Js[0] if len(Js) == 1 else np.concatenate(Js)
        a = As[0] if len(As) == 1 else np.concatenate(As)
        xdot = Xs[0] if len(Xs) == 1 else np.concatenate(Xs)
        if arm_only:
            # joint columns and xdot - J_v v_top (arm-only tasks have zero vehicle columns: their
            # xdot is unchanged), by the compiled copy: summed in the order of the compiled paths
            # (gather_rows), not numpy's (which depends on the CPU's vector width)
            self._one_block[0, 1] = p - start
            copy_arm_rows(
                self._one_block,
                1,
                np.ascontiguousarray(v_top, dtype=float),
                np.ascontiguousarray(J),
                np.ascontiguousarray(a, dtype=float),
                np.ascontiguousarray(xdot, dtype=float),
                stack.J[start:],
                stack.a[start:],
                stack.xdot[start:],
            )
        else:
            stack.a[start:p] = a
            stack.J[start:p] = J
            stack.xdot[start:p] = xdot
        return UNSOLVED

    def _run_batch(self, ctx: TaskContext, t: float, arm_only: bool, steady: bool) -> tuple | None:
        """Evaluate, in one compiled call, the compiled tasks :meth:`_fill` is
        about to use and has not evaluated at this state yet; their outputs go
        to the per-state cache :meth:`_evaluate` reads. Returns the steady
        layout (:meth:`_steady_layout`) when :meth:`_fill_compiled` can stack
        this cycle, else None."""
        batch = self._batch
        cache = self._cache_out
        if steady and not cache:  # the usual cycle: the steady plan's selection
            selection, chosen, frames, layout = self._steady_memo(arm_only)
            if self._selection_set is not selection:  # (else batch.selected holds it already)
                batch.selected[:] = selection
                self._selection_set = selection
        else:
            layout = None
            chosen, frames = self._batch_selection(t, arm_only, steady)
        if chosen:
            batch.run(ctx.kin, ctx.targets, ctx.altitude, frames, ctx.v)
            batch.outputs_into(cache, chosen)
        return layout

    def _steady_memo(self, arm_only: bool) -> tuple:
        """``(selection, chosen, frames, layout)`` of the steady plan of the current
        action on a fresh state (every compiled task of the plan evaluated; TPIK 2's
        when ``arm_only``), built on first use after each action switch, whatever the
        output cache holds: the arm step right after a vehicle step at the same state
        (the runtime's vehicle tick) takes its compiled path from the first cycle."""
        memo = self._steady_batch.get(arm_only)
        if memo is None:
            # (the time is not read for the steady plan: no activation to check)
            chosen, frames = self._batch_selection(0.0, arm_only, True, use_cache=False)
            layout = self._steady_layout(arm_only, chosen)
            memo = self._steady_batch[arm_only] = (self._batch.selected.copy(), chosen, frames, layout)
        return memo

    def _steady_layout(self, arm_only: bool, chosen: list[tuple[str, int]]) -> tuple | None:
        """What :meth:`_fill_compiled` needs for the steady plan, or None when
        some task of it has no compiled kernel (then :meth:`_fill` stacks in Python)."""
        tasks = [
            (li, tk)
            for li, (tasks, *_rest) in enumerate(self._plan)
            for tk in tasks
            if not (arm_only and not tk.USES_ARM)
        ]
        if [tk.name for _li, tk in tasks] != [name for name, _k in chosen]:
            return None
        batch = self._batch
        kinds = [tk.KIND == "inequality" for _li, tk in tasks]
        levels = [(lam, threshold, name) for _tasks, lam, threshold, name in self._plan]
        # the int and float arrays are views of two buffers (kcl.arm_cycle.layout_views)
        bufs = layout_buffers(
            [k for _name, k in chosen],
            [li for li, _tk in tasks],
            kinds,
            [lv[0] for lv in levels],
            [lv[1] for lv in levels],
        )
        s, n_levels = len(chosen), len(levels)
        ibuf, fbuf = bufs
        slots, level_of = ibuf[2 : 2 + s], ibuf[2 + s : 2 + 2 * s]
        level_rows, slot_row = ibuf[2 + 3 * s : 2 + 3 * s + n_levels], ibuf[2 + 3 * s + n_levels :]
        inequality = np.array(kinds, dtype=bool)
        arm_info = [(tk.USES_ARM, li, int(batch.dims[k])) for (li, tk), k in zip(tasks, slots.tolist())]
        names = tuple(name for name, _k in chosen)  # their records come from the cache (current outputs)
        return (
            slots,
            level_of,
            inequality,
            arm_info,
            names,
            levels,
            level_rows,
            slot_row,
            fbuf[:n_levels],
            fbuf[n_levels:],
            bufs,
        )

    def _warm_up_gather(self) -> None:
        """Load (first time: compile) :func:`gather_rows` and :func:`copy_arm_rows`
        with the cycle's types."""
        b = self._batch
        none = np.zeros(0, dtype=np.int64)
        for stack, arm_only in ((self._stack1, False), (self._stack2, True)):
            gather_rows(
                none,
                none,
                np.zeros(0, dtype=bool),
                b.status,
                b.row0,
                b.dims,
                b.A,
                b.J,
                b.XD,
                arm_only,
                self._no_velocity,
                stack.J,
                stack.a,
                stack.xdot,
                0,
                np.zeros(1, dtype=np.int64),
                none,
            )
        s1, s2 = self._stack1, self._stack2
        if self._fused:
            gather_solve(
                none,
                none,
                np.zeros(0, dtype=bool),
                b.status,
                b.row0,
                b.dims,
                b.A,
                b.J,
                b.XD,
                self._no_velocity,
                s2.J,
                s2.a,
                s2.xdot,
                np.zeros(1, dtype=np.int64),
                none,
                np.zeros(1),
                np.zeros(1),
                s2.level_ids,
                s2.offsets,
                s2.lams,
                s2.ths,
                float(self._lam),
                float(self._threshold),
                float(self.config.eta),
                self._jlim,
                s2.raw,
                s2.applied,
                s2.factors,
                np.empty(s2.n),
            )
            lay_i, lay_f = layout_buffers([], [], [], [], [])
            kin_i, kin_f = self._chain if self._chain is not None else self._no_chain
            arm_cycle(
                b.ibuf,
                b.fbuf,
                np.zeros_like(b.selected),
                np.zeros(self._l),
                np.zeros(6),
                np.eye(3),
                lay_i,
                lay_f,
                s2.ibuf,
                s2.fbuf,
                self._no_velocity,
                self._jlim,
                np.empty(s2.n),
                float(self._lam),
                float(self._threshold),
                float(self.config.eta),
                FRAMES_READY,
                kin_i,
                kin_f,
                self._no_velocity,
                np.zeros(7 + self._l),
                0.0,
                0.0,
                0.0,
                0,
            )
            no_compile(arm_cycle)  # loaded: other argument kinds raise TypeError (see _arm_cycle)
            kin_i, kin_f = self._chain if self._chain is not None else self._no_chain
            vehicle_cycle(
                b.ibuf,
                b.fbuf,
                np.zeros_like(b.selected),
                np.zeros(self._l),
                np.zeros(6),
                np.eye(3),
                lay_i,
                lay_f,
                s1.ibuf,
                s1.fbuf,
                self._no_velocity,
                self._no_velocity,
                False,
                float(self._lam),
                float(self._threshold),
                float(self._lam),
                float(self._threshold),
                float(self.config.eta),
                self._limits1,
                self._vlim,
                self._no_velocity,
                kin_i,
                kin_f,
                np.zeros(7 + self._l),
                self._no_velocity,
                0.0,
                0.0,
                np.empty(6),
            )
            no_compile(vehicle_cycle)  # loaded: other argument kinds raise TypeError (see _vehicle_fused)
        copy_arm_rows(self._arm_rows.bounds, 0, self._no_velocity, s1.J, s1.a, s1.xdot, s2.J, s2.a, s2.xdot)

    def _fill_compiled(
        self,
        stack: StackedLevels,
        layout: tuple,
        t: float,
        arm_only: bool,
        v_top: np.ndarray | None,
        limits: np.ndarray | None = None,
    ) -> object:
        """:meth:`_fill` for the steady plan when every task is in the batch
        (a_p = 1): records, then one compiled copy (:func:`kcl.tasks.batch.gather_rows`)
        with the same skips, then the levels closed in order. With ``limits``
        (TPIK 2, compiled solver available, stack empty) the solve and the clip
        run in the same compiled call (:func:`kcl.cycle.gather_solve`): returns
        the clipped joint velocities (None on a fault), else :data:`UNSOLVED`."""
        slots, level_of, inequality, arm_info, names, levels, level_rows, slot_row, *_lt = layout
        self._record_outputs(names, t)
        batch = self._batch
        if limits is not None and arm_only and stack.rows_used == 0 and self._fused:
            return self._gather_solve(stack, layout, v_top, limits)
        level_rows[:] = 0
        v = self._no_velocity if v_top is None else np.ascontiguousarray(v_top, dtype=float)
        start = (stack.count, stack.rows_used)
        gather_rows(
            slots,
            level_of,
            inequality,
            batch.status,
            batch.row0,
            batch.dims,
            batch.A,
            batch.J,
            batch.XD,
            arm_only,
            v,
            stack.J,
            stack.a,
            stack.xdot,
            stack.rows_used,
            level_rows,
            slot_row,
        )
        # usually the same tasks are skipped as last cycle: then the levels (and
        # the TPIK 2 row blocks) are those already written, restore them as is
        memo = self._level_memos.get(arm_only)
        if (
            memo is not None
            and stack.token is memo
            and memo[0] is layout
            and memo[1] == start
            and (arm_only or memo[2] is self._arm_token)
            and memo[3] == slot_row.tobytes()
        ):
            stack.count, stack.rows_used = memo[4], memo[5]
            return UNSOLVED
        self._fill_levels(stack, layout, arm_only)
        memo = (layout, start, self._arm_token, slot_row.tobytes(), stack.count, stack.rows_used)
        self._level_memos[arm_only] = memo
        stack.token = memo
        return UNSOLVED

    def _gather_solve(
        self, stack: StackedLevels, layout: tuple, v_top: np.ndarray | None, limits: np.ndarray
    ) -> np.ndarray | None:
        """TPIK 2 stacked, solved and clipped by :func:`kcl.cycle.gather_solve`
        (one compiled call); the stack's levels are left as :meth:`_fill_levels`
        would leave them. Returns the joint velocities (rad/s), or None after
        recording a fault (the same faults as ``_run_tpik``)."""
        slots, level_of, inequality, _arm_info, _outputs, levels, level_rows, slot_row, level_lams, level_ths, _b = (
            layout
        )
        batch = self._batch
        v = self._no_velocity if v_top is None else np.ascontiguousarray(v_top, dtype=float)
        out = np.empty(stack.n)
        code, count, rows, changed, bad, bad_code = gather_solve(
            slots,
            level_of,
            inequality,
            batch.status,
            batch.row0,
            batch.dims,
            batch.A,
            batch.J,
            batch.XD,
            v,
            stack.J,
            stack.a,
            stack.xdot,
            level_rows,
            slot_row,
            level_lams,
            level_ths,
            stack.level_ids,
            stack.offsets,
            stack.lams,
            stack.ths,
            self._lam_f,
            self._threshold_f,
            self._eta_f,
            limits,
            stack.raw,
            stack.applied,
            stack.factors,
            out,
        )
        return self._solved(stack, levels, out, code, count, rows, changed, bad, bad_code)

    def _arm_fast(
        self, stack: StackedLevels, kin, altitude: float | None, t: float, v_top: np.ndarray | None
    ) -> object:
        """TPIK 2 (``stack`` just cleared) by :meth:`_arm_cycle` when it applies:
        steady plan with its memo, compiled solver, a fresh state (what
        :meth:`_fill` with the joint limits would do the same way); else
        :data:`UNSOLVED` (the caller then runs :meth:`_fill`)."""
        if t - self._t_switch >= self.actions.transition_time and self._fused and not self._cache_out:
            memo = self._steady_memo(True)
            if memo[3] is not None:
                return self._arm_cycle(stack, kin, self._targets, altitude, t, v_top, self._jlim, memo)
        return UNSOLVED

    def _arm_cycle(
        self,
        stack: StackedLevels,
        kin,
        targets,
        altitude,
        t: float,
        v_top: np.ndarray | None,
        limits: np.ndarray,
        memo: tuple,
    ) -> np.ndarray | None:
        """The steady TPIK 2 cycle on a fresh state (:meth:`_run_batch` with
        its memo, then :meth:`_fill_compiled` and :meth:`_gather_solve`, the
        same steps and results) with the task kernels and the solve in one
        compiled call (:func:`kcl.arm_cycle.arm_cycle`). :data:`UNSOLVED`
        (nothing changed but the batch selection) when that call refuses the
        argument kinds: the caller takes the step by step path."""
        selection, chosen, frames, layout = memo
        batch = self._batch
        if self._selection_set is not selection:  # (else batch.selected holds it already)
            batch.selected[:] = selection
            self._selection_set = selection
        chain = self._chain
        mode = FRAMES_READY
        kin_i = kin_f = None
        if chosen:
            if chain is not None:  # the frames computed in the compiled call (kcl.kin_frames)
                mode = FRAMES_COMPUTE
                kin_i, kin_f = chain
            else:  # Pinocchio's, columns reordered in the compiled call
                kin.frames_into(
                    batch.frame_names, frames, batch.P, batch.Jw, batch._Jraw, reorder=False, rows=batch.frame_rows
                )
                mode = FRAMES_REORDER
            batch.set_env(targets, altitude)
        if kin_i is None:
            kin_i, kin_f = self._no_chain
        v = self._no_velocity if v_top is None else v_top  # (another kind of array: TypeError below)
        out = np.empty(stack.n)
        lay_i, lay_f = layout[10]
        try:
            code, count, rows, changed, bad, bad_code = arm_cycle(
                batch.ibuf,
                batch.fbuf,
                batch.selected,
                kin.q,
                kin.eta,
                kin.wRv,
                lay_i,
                lay_f,
                stack.ibuf,
                stack.fbuf,
                v,
                limits,
                out,
                self._lam_f,
                self._threshold_f,
                self._eta_f,
                mode,
                kin_i,
                kin_f,
                self._no_velocity,
                self._qff,
                0.0,
                0.0,
                0.0,
                0,
            )
        except TypeError:  # an array of another kind (never compiled mid-run): the step by step path
            return UNSOLVED
        if chosen:
            batch.outputs_into(self._cache_out, chosen)
        self._record_outputs(layout[4], t)
        return self._solved(stack, layout[5], out, code, count, rows, changed, bad, bad_code)

    def _select_batch(self, selection: np.ndarray, chosen: list, altitude: float | None) -> None:
        """Before a compiled cycle: the batch's selection (written only when another one
        was there) and, when it runs tasks, their targets and the altitude (m)."""
        if self._selection_set is not selection:  # (else batch.selected holds it already)
            self._batch.selected[:] = selection
            self._selection_set = selection
        if chosen:
            self._batch.set_env(self._targets, altitude)

    def _keep_cycle_state(
        self,
        q: np.ndarray,
        eta: np.ndarray,
        t: float,
        key: tuple | None,
        chosen: list[tuple[str, int]],
        names: tuple[str, ...],
    ) -> None:
        """The per-state bookkeeping after a compiled cycle (:mod:`kcl.controller_arm`,
        :mod:`kcl.controller_vehicle`) at joints ``q`` / pose ``eta`` (the checked
        inputs), time ``t`` (s): a new state ``key`` (None: the cached state) empties
        the output cache and drops the kinematics snapshot (built when asked for,
        :meth:`kcl.controller_inputs.InputsMixin._kinematics`); the batch tasks the
        call ran (``chosen``) go to the cache, the plan's tasks (``names``) to the records."""
        self._q_in, self._eta_in = q, eta
        self._t_last = float(t)
        if key is not None:
            self._cache_key = key
            self._cache_kin = None
            self._cache_out = {}
        if chosen:
            self._batch.outputs_into(self._cache_out, chosen)
        self._record_outputs(names, t)

    def _record_outputs(self, names: tuple[str, ...], t: float) -> None:
        """``_records[name] = (t, activation, output)`` of the tasks ``names`` from their
        outputs at this state (the per-state cache; a_p = 1: the steady plan)."""
        records, cache = self._records, self._cache_out
        for name in names:
            o = cache[name]
            records[name] = (t, o.a, o)

    def _solved(
        self,
        stack: StackedLevels,
        levels: list,
        out: np.ndarray,
        code: int,
        count: int,
        rows: int,
        changed: bool,
        bad: int,
        bad_code: int,
    ) -> np.ndarray | None:
        """Book-keeping after :func:`kcl.cycle.gather_solve`: the stack's level
        count, rows and names; ``out``, or None after recording the fault."""
        stack.count, stack.rows_used, stack.token = count, rows, None
        if changed:  # level names (error messages, tests) only when the layout changed
            stack.names[:count] = [levels[li][2] for li in stack.level_ids[:count].tolist()]
        if code == SOLVED:
            return out
        self._solver_fault(stack, code, bad, bad_code)
        return None

    def _solver_fault(self, stack: StackedLevels, code: int, bad: int, bad_code: int) -> None:
        """Record the fault of a compiled cycle's status ``code`` (not SOLVED): the
        same reasons as ``_run_tpik``'s."""
        if code == BAD_INPUT:
            self._fail(f"solver refused the task data: {_label(bad, stack.names[bad])}: {CHECK_MESSAGES[bad_code]}")
        else:
            self._fail("solver returned a non-finite velocity")

    def _fill_levels(self, stack: StackedLevels, layout: tuple, arm_only: bool) -> None:
        """Close the levels :func:`gather_rows` just filled (and, for TPIK 1,
        note the arm-using row blocks and levels for :meth:`_derive_arm_stack`)."""
        _slots, _level_of, _inequality, arm_info, _outputs, levels, level_rows, slot_row, *_lt = layout
        counts = level_rows.tolist()
        for (lam, threshold, name), rows in zip(levels, counts):
            if rows:
                stack.close_level(rows, lam, threshold, name)
        if arm_only:
            return
        arm_rows = self._arm_rows
        arm_rows.clear()
        self._arm_levels.clear()
        self._arm_token = object()
        arm_counts = [0] * len(levels)
        for (uses_arm, li, m), row in zip(arm_info, slot_row.tolist()):
            if uses_arm and row >= 0:
                arm_rows.add(row, row + m)
                arm_counts[li] += m
        self._arm_levels.extend((c, lam, threshold, name) for (lam, threshold, name), c in zip(levels, arm_counts) if c)

    def _batch_selection(
        self, t: float, arm_only: bool, steady: bool, use_cache: bool = True
    ) -> tuple[list[tuple[str, int]], set[int]]:
        """Set the batch's selection to the compiled tasks :meth:`_fill` will
        evaluate and are not cached (``use_cache`` False: cached or not); returns
        their (name, slot) and frames."""
        batch = self._batch
        index = batch.index
        cache = self._cache_out if use_cache else {}
        selected = batch.selected
        selected[:] = False
        self._selection_set = None
        chosen: list[tuple[str, int]] = []
        frames: set[int] = set()
        for tasks, _lam, _threshold, _name in self._plan if steady else self._full_plan:
            for task in tasks:
                k = index.get(task.name)
                if k is None or task.name in cache or (arm_only and not task.USES_ARM):
                    continue
                if not steady and self._ap(task.name, t) <= 0.0:
                    continue
                selected[k] = True
                chosen.append((task.name, k))
                frames.update(batch.task_frames[k])
        return chosen, frames

    def _derive_arm_stack(self, v_top: np.ndarray) -> None:
        """TPIK 2's stack from TPIK 1's, filled at the same state and time: the
        arm-using tasks' rows, joint columns, ``xdot - J_v v_top``. Same rows,
        levels and a_p as :meth:`_fill` with ``arm_only`` (arm-only tasks have
        zero vehicle columns, so the subtraction leaves their xdot unchanged).
        Not used when a velocity task acts on the arm (TPIK 2 evaluates those
        with another velocity). One compiled copy (:func:`kcl.tasks.batch.copy_arm_rows`)."""
        s1, s2 = self._stack1, self._stack2
        s2.clear()
        rr = self._arm_rows
        copy_arm_rows(
            rr.bounds, rr.n, np.ascontiguousarray(v_top, dtype=float), s1.J, s1.a, s1.xdot, s2.J, s2.a, s2.xdot
        )
        memo = self._derive_memo
        if memo is not None and s2.token is memo and memo[0] is self._arm_token:
            s2.count, s2.rows_used = memo[1], memo[2]  # same levels as last time, still written
            return
        for count, lam, threshold, name in self._arm_levels:
            s2.close_level(count, lam, threshold, name)
        self._derive_memo = s2.token = (self._arm_token, s2.count, s2.rows_used)


class RowRanges:
    """A set of stack rows kept as sorted ``[start, stop)`` blocks in
    ``bounds[:n]`` (an int64 array, for :func:`kcl.tasks.batch.copy_arm_rows`;
    adjacent additions merge), with the total row ``count``."""

    def __init__(self, capacity: int = 16) -> None:
        self.bounds = np.zeros((max(1, capacity), 2), dtype=np.int64)
        self.n = 0
        self.count = 0

    @property
    def ranges(self) -> list[tuple[int, int]]:
        return [(int(a), int(b)) for a, b in self.bounds[: self.n]]

    def clear(self) -> None:
        self.n = 0
        self.count = 0

    def add(self, start: int, stop: int) -> None:
        n = self.n
        bounds = self.bounds
        if n and bounds[n - 1, 1] == start:
            bounds[n - 1, 1] = stop
        else:
            if n == bounds.shape[0]:
                self.bounds = bounds = np.concatenate([bounds, np.zeros_like(bounds)])
            bounds[n, 0] = start
            bounds[n, 1] = stop
            self.n = n + 1
        self.count += stop - start


def derivable(tasks: list[Task]) -> bool:
    """Whether TPIK 2's stack can be taken from TPIK 1's (no velocity task on the arm)."""
    return not any(tk.KIND == "velocity" and tk.USES_ARM for tk in tasks)
