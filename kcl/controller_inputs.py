"""The controller's per-step inputs: their check and the kinematics snapshot
(a mixin of :class:`kcl.controller.UvmsController`, kept apart from the
control steps).

:meth:`InputsMixin._check` tests the measurement (shapes: a programming error,
ValueError; non-finite values: a field fault, returned as a reason) and keeps
the float arrays it converted (``_q_in``, ``_eta_in``), which
:meth:`InputsMixin._context` then uses: every step checks its measurement
first, so they are those of the same measurement. Arrays that already are
float64 ndarrays are used as they are (what ``np.asarray(x, dtype=float)``
returns for them, without its cost).
"""

from __future__ import annotations

import math

import numpy as np

from kcl.controller_types import MeasuredState
from kcl.cycle import finite_total
from kcl.model import Kinematics
from kcl.tasks import TaskContext

_ND = np.ndarray
_F8 = np.dtype(float)


class InputsMixin:
    """Input check and per-state kinematics cache of the controller (reads
    ``_l``, ``_targets``, ``_targets_finite``, ``_no_velocity``,
    ``_targets_version``, ``model``, ``_actuated``; writes ``_q_in``, ``_eta_in``
    and the per-state cache ``_cache_key`` / ``_cache_kin`` / ``_cache_out``)."""

    def _context(self, meas: MeasuredState, v: np.ndarray) -> TaskContext:
        """Task inputs at ``meas`` (checked by :meth:`_check` just before), the
        kinematics snapshot and task outputs shared while the state is the same."""
        return TaskContext(self._kinematics(meas), self._targets, meas.altitude, v, self._actuated)

    def _kinematics(self, meas: MeasuredState) -> Kinematics:
        """The kinematics snapshot at ``meas`` (checked by :meth:`_check` just
        before); a new state also empties the per-state task output cache."""
        q, eta = self._q_in, self._eta_in
        key = (q.tobytes(), eta.tobytes(), meas.altitude, self._targets_version)
        if key != self._cache_key:
            self._cache_key = key
            self._cache_kin = self.model.kinematics(q, eta)
            self._cache_out = {}
        elif self._cache_kin is None:  # the fused arm step (kcl.controller_arm) left it to be built
            self._cache_kin = self.model.kinematics(q, eta)
        return self._cache_kin

    def _check(self, meas: MeasuredState) -> str:
        """Reason why ``meas`` / the targets cannot be used ('' if fine)."""
        q, eta, v = meas.q, meas.eta, meas.v
        if q.__class__ is not _ND or q.dtype is not _F8:
            q = np.asarray(q, dtype=float)
        if eta.__class__ is not _ND or eta.dtype is not _F8:
            eta = np.asarray(eta, dtype=float)
        self._q_in, self._eta_in = q, eta
        if q.shape != self._q_shape or eta.shape != (6,):
            raise ValueError(f"MeasuredState: q must be ({self._l},) and eta (6,), got {q.shape} and {eta.shape}")
        if v is not None and (v.__class__ is not _ND or v.dtype is not _F8):
            v = np.asarray(v, dtype=float)
        if v is not None and v.shape != (6,):
            raise ValueError(f"MeasuredState.v must be (6,), got {v.shape}")
        tg = self._targets
        scalars = (meas.t, 0.0 if meas.altitude is None else meas.altitude)
        # fast path: a sum of squares is finite iff every entry is (or it overflowed:
        # the detailed checks below then find nothing and return "")
        if self._targets_finite:
            try:  # one compiled call (kcl.cycle); TypeError: arrays of another kind (read-only, strided)
                if finite_total(q, eta, self._no_velocity if v is None else v, float(scalars[0]), float(scalars[1])):
                    return ""
            except TypeError:
                total = float(q @ q) + float(eta @ eta) + scalars[0] + scalars[1]
                if v is not None:
                    total += float(v @ v)
                if math.isfinite(total):
                    return ""
        if not (np.isfinite(q).all() and np.isfinite(eta).all()):
            return "non-finite joint positions or vehicle pose"
        if v is not None and not np.isfinite(v).all():
            return "non-finite measured vehicle velocity"
        if not math.isfinite(scalars[1]):
            return "non-finite altitude"
        if not math.isfinite(scalars[0]):
            return "non-finite measurement time"
        for name, value in (
            ("tool_goal", tg.tool_goal),
            ("vehicle_goal", tg.vehicle_goal),
            ("camera_target", tg.camera_target),
        ):
            if value is not None and not np.isfinite(value).all():
                return f"non-finite {name}"
        return ""  # everything finite (the fast path's sum overflowed)
