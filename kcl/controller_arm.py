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
(:meth:`kcl.controller_inputs.InputsMixin._kinematics`). Any other step, or
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

_ND = np.ndarray
_F8 = np.dtype(float)


class FusedArmMixin:
    """:meth:`_arm_fused` (reads and writes the controller's step state, as
    ``_check``, ``_arm_step`` and ``_arm_cycle`` do)."""

    def _arm_fused(self, meas: MeasuredState, t: float) -> object:
        """TPIK 2 at ``t`` (s) for ``meas`` in one compiled call when it applies
        (see the module docstring): the joint velocity references (a copy), or
        :data:`UNSOLVED` (nothing done: run the step by step path)."""
        if self._stopped or not self._targets_finite or self._chain is None or not self._fused:
            return UNSOLVED
        if t - self._t_switch < self.actions.transition_time or not self.config.compensation:
            return UNSOLVED
        memo = self._steady_batch.get(True)
        if memo is None or memo[3] is None:
            return UNSOLVED
        q, eta, v = meas.q, meas.eta, meas.v
        if v is None:
            return UNSOLVED
        # as InputsMixin._check: float64 ndarrays as they are
        if q.__class__ is not _ND or q.dtype is not _F8:
            q = np.asarray(q, dtype=float)
        if eta.__class__ is not _ND or eta.dtype is not _F8:
            eta = np.asarray(eta, dtype=float)
        if v.__class__ is not _ND or v.dtype is not _F8:
            v = np.asarray(v, dtype=float)
        if q.shape != self._q_shape or eta.shape != (6,) or v.shape != (6,):
            return UNSOLVED  # (the step by step path raises its ValueError)
        filt = self._filter
        y_t = filt._t
        if y_t is None:
            return UNSOLVED
        altitude = meas.altitude
        key = (q.tobytes(), eta.tobytes(), altitude, self._targets_version)
        if key == self._cache_key or (self._derived_key is not None and self._derived_key == (key, t)):
            return UNSOLVED  # a state seen already (its task outputs are cached)
        t_meas = float(meas.t)
        dt = t_meas - y_t
        step = dt > 0.0
        k = 1.0 - math.exp(-filt.cutoff_rad_s * dt) if step else 0.0
        selection, chosen, _frames, layout = memo
        batch = self._batch
        if self._selection_set is not selection:  # (else batch.selected holds it already)
            batch.selected[:] = selection
            self._selection_set = selection
        if chosen:
            batch.set_env(self._targets, altitude)
            mode = FRAMES_COMPUTE
        else:
            mode = FRAMES_READY
        kin_i, kin_f = self._chain
        stack = self._stack2
        y = filt._y
        out = np.empty(stack.n)
        lay_i, lay_f = layout[10]
        try:
            code, count, rows, changed, bad, bad_code = arm_cycle(
                batch.ibuf, batch.fbuf, batch.selected, q, eta, self._wRv, lay_i, lay_f, stack.ibuf, stack.fbuf, y,
                self._jlim, out, self._lam_f, self._threshold_f, self._eta_f, mode, kin_i, kin_f, v, self._qff, t_meas,
                0.0 if altitude is None else float(altitude), k, 2 if step else 1)
        except TypeError:  # an array of another kind (never compiled mid-run): the step by step path
            return UNSOLVED
        if code == INPUTS_NOT_FINITE:
            return UNSOLVED  # nothing changed: the step by step path reports the fault
        # the state _check, the filter and _arm_step leave
        self._q_in, self._eta_in = q, eta
        self._t_last = float(t)
        if step:
            filt._t = t_meas
        self._v_tpik2 = y.copy()
        self._v_source2 = "measured"
        self._cache_key = key
        self._cache_kin = None  # built when asked for (InputsMixin._kinematics)
        self._cache_out = cache = {}
        if chosen:
            batch.outputs_into(cache, chosen)
        records = self._records
        for name, o in layout[4]:
            records[name] = (t, o.a, o)
        return self._arm_result(self._solved(stack, layout[5], out, code, count, rows, changed, bad, bad_code))
