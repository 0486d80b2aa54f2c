"""What the controller reports: task errors, convergence of an action's goal
tasks, and the JSON-able telemetry the runtime logs (a mixin of
:class:`kcl.controller.UvmsController`, kept apart from the control steps).

Telemetry keys: ``action``, ``previous_action``, ``transition_progress``,
``stopped``, ``fault`` / ``fault_reason`` / ``fault_count``, ``compensation``,
``vehicle_reference`` (m/s, rad/s, vehicle frame), ``joint_reference`` (rad/s),
``filtered_velocity`` (the low-pass filtered measured vehicle velocity, None
before the first measurement), ``tpik1_velocity_source`` / ``tpik2_velocity_source``
(``measured`` or ``commanded``: what the top, measured-velocity task of each
TPIK used in its last step), ``tpik2_vehicle_velocity`` (what the arm
compensated), ``convergence``, ``tasks`` (per task: activation, error,
reference, note).

:meth:`ReportingMixin.status` gives the few of those fields the mission tree
reads at every tick (:data:`STATUS_KEYS`, the same values) without building
the whole snapshot; :func:`controller_status` calls it, or ``telemetry()`` on a
controller without it (test doubles).
"""

from __future__ import annotations

import math
from typing import Any, NamedTuple, TypedDict

import numpy as np


class _TaskRecord(NamedTuple):
    """Last evaluation of one task (for telemetry and convergence)."""

    t: float
    activation: np.ndarray
    error: np.ndarray
    xdot: np.ndarray
    note: str


class ControllerStatus(TypedDict):
    """The fields of :meth:`ReportingMixin.telemetry` the mission tree reads every
    tick (same keys, same values): time of the last step (s), current action,
    stopped, transition progress (0..1), fault and its reason, convergence of the
    current action (None: no action, or a goal task not evaluated yet)."""

    t: float
    action: str | None
    stopped: bool
    transition_progress: float
    fault: bool
    fault_reason: str
    convergence: float | None


#: the keys of :class:`ControllerStatus`
STATUS_KEYS = tuple(ControllerStatus.__annotations__)


def controller_status(controller: Any) -> ControllerStatus:
    """``controller.status()``, or ``controller.telemetry()`` (a mapping with at
    least those keys) for a controller without ``status``."""
    fn = getattr(controller, "status", None)
    return fn() if fn is not None else controller.telemetry()


class ReportingMixin:
    """Reporting methods of the controller (they read its state, never change it)."""

    def task_errors(self) -> dict[str, float]:
        """Norm of each task's last error (task units); NaN for a task never run."""
        return {n: (_norm(out.error) if not out.note else math.nan) for n, (_t, _a, out) in self._records.items()}

    def _record(self, name: str) -> _TaskRecord | None:
        raw = self._records.get(name)
        if raw is None:
            return None
        t, a, out = raw
        return _TaskRecord(t, a, out.error, out.xdot, out.note)

    def convergence(self, action: str | None = None) -> float:
        """Largest error norm among the goal tasks of ``action`` (default: current;
        goal tasks are its equality tasks unless the file says ``goal: false``),
        from their last evaluation: e.g. < 0.02 means "posture reached" for
        ``transport`` (rad) or "tool at the grasp frame" for ``grasp`` (m, rad).
        ``inf`` if one of them has not run yet or has no target."""
        worst = 0.0
        tasks = self.actions.tasks
        records = self._records
        for name in self.action_tasks(action):
            if not tasks[name].is_goal:
                continue
            raw = records.get(name)
            if raw is None or raw[2].note:
                return math.inf
            worst = max(worst, _norm(raw[2].error))
        return worst

    def status(self) -> ControllerStatus:
        """The :data:`STATUS_KEYS` fields of :meth:`telemetry`, the same values,
        at a fraction of its cost (no per-task lists)."""
        t = self._t_last
        fault = self._fault
        return {
            "t": t,
            "action": self._action,
            "stopped": self._stopped,
            "transition_progress": self.transition_progress(t),
            "fault": fault,
            "fault_reason": self._fault_reason if fault else "",
            "convergence": None if self._action is None else _json_float(self.convergence()),
        }

    def telemetry(self) -> dict[str, Any]:
        """JSON-able snapshot for the log (lists of floats, strings, bools)."""
        t = self._t_last
        tasks = {}
        records = self._records
        ap_from, ap_to = self._ap_from, self._ap_to
        for name in self._task_order:
            raw = records.get(name)
            if raw is None:
                continue
            rec_t, activation, out = raw
            start, end = ap_from[name], ap_to[name]
            tasks[name] = {
                "t": rec_t,
                "a_p": end if start == end else self._ap(name, t),  # (no call outside transitions)
                "activation": activation.tolist(),
                "error": out.error.tolist(),
                "reference": out.xdot.tolist(),
                "note": out.note,
            }
        v_f = self._filter.value
        return {
            "t": t,
            "action": self._action,
            "previous_action": self._prev_action,
            "transition_progress": self.transition_progress(t),
            "stopped": self._stopped,
            "fault": self._fault,
            "fault_reason": self._fault_reason if self._fault else "",
            "fault_count": self._fault_count,
            "compensation": self.config.compensation,
            "vehicle_reference": self._v_cmd.tolist(),
            "joint_reference": self._qdot_cmd.tolist(),
            "filtered_velocity": None if v_f is None else v_f.tolist(),
            "tpik2_vehicle_velocity": self._v_tpik2.tolist(),  # what the arm compensated
            "tpik1_velocity_source": self._v_source1,
            "tpik2_velocity_source": self._v_source2,
            "convergence": None if self._action is None else _json_float(self.convergence()),
            "tasks": tasks,
        }


def _norm(x: np.ndarray) -> float:
    """Euclidean norm of a float vector: its squares summed one after the other in
    double precision (an explicit loop: no compensated ``sum``, no FMA), so the same
    number on every machine. (numpy's ``dot``, as in ``np.linalg.norm``, sums in an
    order that depends on the CPU's vector instructions: the last bit of a logged
    error then depended on the machine that made the run.)"""
    total = 0.0
    for v in x.ravel().tolist():
        total += v * v
    return math.sqrt(total)


def _json_float(x: float) -> float | None:
    return x if math.isfinite(x) else None
