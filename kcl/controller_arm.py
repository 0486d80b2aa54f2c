"""The usual arm step in ONE compiled call, inputs included (a mixin of
:class:`kcl.controller.UvmsController`).

Most arm steps (steady plan, a new measured state, compensation on, a velocity
measurement, the filter started) are a fixed sequence: the input check
(:meth:`kcl.controller_inputs.InputsMixin._check`), the low-pass step of the
measured vehicle velocity (:meth:`kcl.filters.FirstOrderLowPass.feed`), the
kinematics set-up (:class:`kcl.model.Kinematics`), then the task kernels, the
stack, the solve and the clip (:meth:`kcl.stacking.StackingMixin._arm_cycle`).
:meth:`FusedArmMixin._arm_fused` runs all of them in the one call of
:func:`kcl.arm_cycle.arm_cycle` (its ``prep`` part), the same operations in
the same order (the same numbers, bit for bit), and leaves the controller in
the state :meth:`kcl.controller.UvmsController._arm_step` would; the
kinematics snapshot of the state is then built only if something asks for it
(:meth:`kcl.controller_inputs.InputsMixin._kinematics`).

A state seen already (the same joints, pose, altitude and targets: the arm
step right after a vehicle step, or in the field an arm step between two
navigation or joint readings) takes the same call with the task rows of that
state still in the batch: only the plan's velocity tasks run again, the frames
are not recomputed. Its xdot - J_v v_top is summed in the compiled loop where
the step by step path uses numpy's matrix product (the same numbers up to
rounding, not bit for bit). Any other step, or
a non-finite input (the step by step path finds the reason and reports the
fault), returns :data:`kcl.stacking.UNSOLVED` having changed nothing that
matters: the caller runs the step by step path.
"""

from __future__ import annotations

import math

import numpy as np

from kcl.arm_cycle import FRAMES_COMPUTE, FRAMES_READY, INPUTS_NOT_FINITE, arm_cycle
from kcl.controller_types import MeasuredState
from kcl.stacking import UNSOLVED


class FusedArmMixin:
    """:meth:`_arm_fused` (reads and writes the controller's step state, as
    ``_check``, ``_arm_step`` and ``_arm_cycle`` do)."""

    #: (steady memo, selection, chosen) of :meth:`_repeat_selection`
    _repeat_memo: tuple | None = None

    def _arm_fused(self, meas: MeasuredState, t: float) -> object:
        """TPIK 2 at ``t`` (s) for ``meas`` in one compiled call when it applies
        (see the module docstring): the joint velocity references (a copy), or
        :data:`UNSOLVED` (nothing done: run the step by step path)."""
        if self._stopped or not self._targets_finite or self._chain is None or not self._fused:
            return UNSOLVED
        if t - self._t_switch < self.actions.transition_time or not self.config.compensation:
            return UNSOLVED
        memo = self._steady_memo(True)
        if memo[3] is None:
            return UNSOLVED
        q, eta, v = meas.q, meas.eta, meas.v
        if v is None:
            return UNSOLVED
        # (arrays as kernel_ready leaves them: the public steps pass it first)
        if q.shape != self._q_shape or eta.shape != (6,) or v.shape != (6,):
            return UNSOLVED  # (the step by step path raises its ValueError)
        filt = self._filter
        y_t = filt._t
        if y_t is None:
            return UNSOLVED
        altitude = meas.altitude
        key = (q.tobytes(), eta.tobytes(), altitude, self._targets_version)
        selection, chosen, _frames, layout = memo
        repeat = key == self._cache_key  # a state seen already: its task outputs are in the batch
        if repeat:
            cache = self._cache_out
            for name, _k in chosen:
                if name not in cache:  # (evaluated at this state by a plan of another step)
                    return UNSOLVED
            selection, chosen = self._repeat_selection(memo)
        t_meas = float(meas.t)
        dt = t_meas - y_t
        step = dt > 0.0
        k = 1.0 - math.exp(-filt.cutoff_rad_s * dt) if step else 0.0
        batch = self._batch
        self._select_batch(selection, chosen, altitude)
        mode = FRAMES_COMPUTE if chosen and not repeat else FRAMES_READY
        kin_i, kin_f = self._chain
        stack = self._stack2
        y = filt._y
        out = np.empty(stack.n)
        lay_i, lay_f = layout[10]
        try:
            code, count, rows, changed, bad, bad_code = arm_cycle(
                batch.ibuf,
                batch.fbuf,
                batch.selected,
                q,
                eta,
                self._wRv,
                lay_i,
                lay_f,
                stack.ibuf,
                stack.fbuf,
                y,
                self._jlim,
                out,
                self._lam_f,
                self._threshold_f,
                self._eta_f,
                mode,
                kin_i,
                kin_f,
                v,
                self._qff,
                t_meas,
                0.0 if altitude is None else float(altitude),
                k,
                2 if step else 1,
            )
        except TypeError:  # an array of another kind (never compiled mid-run): the step by step path
            return UNSOLVED
        if code == INPUTS_NOT_FINITE:
            return UNSOLVED  # nothing changed: the step by step path reports the fault
        # the state _check, the filter and _arm_step leave
        if step:
            filt._t = t_meas
        self._v_tpik2 = y.copy()
        self._v_source2 = "measured"
        self._keep_cycle_state(q, eta, t, None if repeat else key, chosen, layout[4])
        return self._arm_result(self._solved(stack, layout[5], out, code, count, rows, changed, bad, bad_code))

    def _repeat_selection(self, memo: tuple) -> tuple[np.ndarray, list[tuple[str, int]]]:
        """The batch selection and ``(name, slot)`` list of the steady arm plan ``memo``
        on a state seen already: its velocity tasks only (evaluated again every step,
        as :meth:`kcl.controller.UvmsController._evaluate` does; the others' rows at
        this state are still in the batch)."""
        held = self._repeat_memo
        if held is not None and held[0] is memo:
            return held[1], held[2]
        batch = self._batch
        chosen = [(name, k) for name, k in memo[1] if batch.tasks[k].KIND == "velocity"]
        selection = np.zeros_like(batch.selected)
        for _name, k in chosen:
            selection[k] = True
        self._repeat_memo = (memo, selection, chosen)
        return selection, chosen
