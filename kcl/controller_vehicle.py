"""The usual vehicle step in ONE compiled call, inputs included (a mixin of
:class:`kcl.controller.UvmsController`).

In the steady plan (no transition running, every task of the action with a
row kernel, the kinematics computed in compiled code), TPIK 1 is a fixed
sequence: :meth:`FusedVehicleMixin._vehicle_fused` runs it in the one call of
:func:`kcl.vehicle_cycle.vehicle_cycle` (the same operations in the same order
as :meth:`kcl.controller.UvmsController._vehicle_step`, the same numbers) and
leaves the controller in the state that step would, but for one thing: it does
not mark TPIK 1's stack for TPIK 2 to copy rows from (``_derived_key``); the
arm step that follows at the same state takes its own compiled call on the
task rows still in the batch (:mod:`kcl.controller_arm`). Any other step, or a
non-finite input (the step by step path finds the reason and reports the
fault), returns :data:`kcl.stacking.UNSOLVED` having changed nothing that
matters: the caller runs the step by step path.
"""

from __future__ import annotations

import numpy as np

from kcl.controller_types import MeasuredState
from kcl.stacking import UNSOLVED
from kcl.vehicle_cycle import INPUTS_NOT_FINITE, TOP_LEVEL, vehicle_cycle


class FusedVehicleMixin:
    """:meth:`_vehicle_fused` (reads and writes the controller's step state, as
    ``_check`` and ``_vehicle_step`` do)."""

    def _vehicle_fused(self, meas: MeasuredState, t: float) -> object:
        """TPIK 1 at ``t`` (s) for ``meas`` in one compiled call when it applies (see
        the module docstring): the body velocity reference (6,) (a copy), or
        :data:`UNSOLVED` (nothing done: run the step by step path)."""
        if self._stopped or not self._targets_finite or self._chain is None or not self._fused:
            return UNSOLVED
        if t - self._t_switch < self.actions.transition_time:
            return UNSOLVED
        memo = self._steady_memo(False)
        if memo[3] is None:
            return UNSOLVED
        q, eta, v = meas.q, meas.eta, meas.v
        # (arrays as kernel_ready leaves them: the public steps pass it first)
        if q.shape != self._q_shape or eta.shape != (6,) or (v is not None and v.shape != (6,)):
            return UNSOLVED  # (the step by step path raises its ValueError)
        if v is not None:  # the filtered measurement (the raw one before the first arm step)
            v_top = self._filter.value
            if v_top is None:
                v_top = v
            source = "measured"
        else:  # no measurement: never a stale filtered value (see kcl.controller)
            v_top = self._v_cmd
            source = "commanded"
        altitude = meas.altitude
        selection, chosen, _frames, layout = memo
        batch = self._batch
        self._select_batch(selection, chosen, altitude)
        kin_i, kin_f = self._chain
        stack = self._stack1
        out = np.empty(6)
        lay_i, lay_f = layout[10]
        top = not self._all_actuated
        try:
            code, count, rows, changed, bad, bad_code = vehicle_cycle(
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
                v_top,
                self._a_top1,
                top,
                self._lam_f,
                self._threshold_f,
                self._lam_f,
                self._threshold_f,
                self._eta_f,
                self._limits1,
                self._vlim,
                self._actuated_f,
                kin_i,
                kin_f,
                self._qff,
                self._no_velocity if v is None else v,
                float(meas.t),
                0.0 if altitude is None else float(altitude),
                out,
            )
        except TypeError:  # an array of another kind (never compiled mid-run): the step by step path
            return UNSOLVED
        if code == INPUTS_NOT_FINITE:
            return UNSOLVED  # nothing changed: the step by step path reports the fault
        # the state _check and _vehicle_step leave
        self._derived_key = None
        self._v_source1 = source
        self._v_tpik1 = np.array(v_top, dtype=float)
        self._keep_cycle_state(
            q, eta, t, (q.tobytes(), eta.tobytes(), altitude, self._targets_version), chosen, layout[4]
        )
        levels = layout[5]
        stack.count, stack.rows_used, stack.token = count, rows, None
        if changed:  # level names (error messages, tests) only when the layout changed
            stack.names[:count] = [
                self._top1.name if li == TOP_LEVEL else levels[li][2] for li in stack.level_ids[:count].tolist()
            ]
        if code != 0:
            self._solver_fault(stack, code, bad, bad_code)
            self._v_cmd = np.zeros(6)
            return np.zeros(6)
        self._v_cmd = out
        self._fault = False
        return out.copy()
