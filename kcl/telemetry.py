"""What the controller reports: its step state, the mission tree's status, the
convergence of an action's goal tasks and the JSON-able telemetry the runtime logs.

Telemetry keys: ``t``, ``action``, ``previous_action``, ``transition_progress``,
``stopped``, ``fault`` / ``fault_reason`` / ``fault_count``, ``compensation``,
``vehicle_reference`` (m/s, rad/s, vehicle frame), ``joint_reference`` (rad/s),
``filtered_velocity`` (the low-pass filtered measured vehicle velocity, None
before the first measurement), ``tpik2_vehicle_velocity`` (what the arm
compensated), ``tpik1_velocity_source`` / ``tpik2_velocity_source`` (``measured``
or ``commanded``: what the top, measured-velocity task of each TPIK used in its
last step), ``convergence``, ``tasks`` (per task as last stacked: time, a_p,
activation, error, reference, the rate the last commands give it, note),
``limited`` (the tasks of the current action that the last commands move at
less than 90 % of their reference, with the active inequality tasks above them:
what held them back, e.g. a joint limit stopping an operator's jog).

The telemetry is taken in two parts: :meth:`TelemetrySnapshot.take` keeps what
changes from step to step (the step state and the blend, the batch's row values
and the commanded rates as Python floats), and :meth:`TelemetrySnapshot.message`
builds the JSON-able dict from it, at any later time. The runtime takes the
snapshot at the step it reports and builds the message at the next step, so that
the tree step, the loop's longest, does not also carry the message.

:func:`status` (the controller's ``status()``) gives the few of those fields the
mission tree reads at every tick (:data:`STATUS_KEYS`, the same values) without
building the whole snapshot.
"""

from __future__ import annotations

import copy
import math
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field
from typing import Any, TypedDict

import numpy as np

from kcl.actions import ActionSet
from kcl.blend import ActionBlend
from kcl.filters import FirstOrderLowPass
from kcl.tasks.batch import IDLE_NOTES, TaskBatch


@dataclass
class StepState:
    """The controller's results of its last steps (read by the reports).

    ``t``: time of the last step (s); ``v_cmd`` (6,) / ``qdot_cmd`` (l,): the last
    vehicle and joint references (zeros after a stop or a fault); ``v_tpik1`` /
    ``v_tpik2``: the velocity the top task of each TPIK was given, and whether it
    was ``measured`` or ``commanded``; the fault of the last step and how many
    steps faulted."""

    v_cmd: np.ndarray
    qdot_cmd: np.ndarray
    t: float = 0.0
    fault: bool = False
    fault_reason: str = ""
    fault_count: int = 0
    v_tpik1: np.ndarray | None = None
    v_tpik2: np.ndarray = field(default_factory=lambda: np.zeros(6))
    source1: str = "commanded"
    source2: str = "commanded"

    def __copy__(self) -> StepState:
        """A shallow copy (the telemetry snapshot's): the controller replaces the
        arrays at each step and never writes into them."""
        twin = object.__new__(StepState)
        twin.__dict__.update(self.__dict__)
        return twin

    def fail(self, reason: str) -> None:
        """Record a fault of this step."""
        self.fault = True
        self.fault_reason = reason
        self.fault_count += 1


class ControllerStatus(TypedDict):
    """The fields of the telemetry the mission tree reads every tick (same keys,
    same values): time of the last step (s), current action, stopped, transition
    progress (0..1), fault and its reason, convergence of the current action
    (None: no action, or a goal task not evaluated yet)."""

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
    least those keys) for a controller without ``status`` (test doubles)."""
    fn = getattr(controller, "status", None)
    report: ControllerStatus = fn() if fn is not None else controller.telemetry()
    return report


@dataclass(slots=True)
class RowValues:
    """The batch's row values as Python floats (the log's values), converted once
    for all the reports of one message: activations (without the action-transition
    factor), errors, references, the rates the last commands give the rows
    (:func:`commanded_rates`), and per task its record time (NaN: never stacked),
    its a_p at that time and its idle status (0: active)."""

    activation: list[float]
    error: list[float]
    reference: list[float]
    rate: list[float]
    t_rec: list[float]
    ap_rec: list[float]
    status: list[int]

    @classmethod
    def of(cls, state: StepState, batch: TaskBatch) -> RowValues:
        """The row values of ``batch`` now, under the last commands of ``state``."""
        return cls(
            batch.A.tolist(),
            batch.E.tolist(),
            batch.XD.tolist(),
            commanded_rates(state, batch).tolist(),
            batch.t_rec.tolist(),
            batch.ap_rec.tolist(),
            batch.status.tolist(),
        )


def convergence(actions: ActionSet, batch: TaskBatch, action: str | None, rows: RowValues | None = None) -> float:
    """Largest error norm among the goal tasks of ``action`` (goal tasks are its
    equality tasks unless the file says ``goal: false``), from their last
    evaluation: e.g. < 0.02 means "posture reached" for ``transport`` (rad) or
    "tool at the grasp frame" for ``grasp`` (m, rad). ``inf`` if one of them has
    not run yet or has no target; 0 without an action. The norms are summed in
    index order, so the same inputs give the same last bit on every machine.
    ``rows``: the batch's values to read (default: the batch's arrays now)."""
    if action is None:
        return 0.0
    worst = 0.0
    for name in actions.tasks_of(action):
        if not actions.tasks[name].is_goal:
            continue
        k = batch.index[name]
        if rows is None:  # Python floats: numpy scalars cost far more per element
            active, never = batch.status[k] == 0, math.isnan(batch.t_rec[k])
            norm = _norm(batch.E[batch.slices[k]].tolist()) if active else math.nan
        else:
            active, never = rows.status[k] == 0, math.isnan(rows.t_rec[k])
            norm = _norm(rows.error[batch.slices[k]]) if active else math.nan
        if math.isnan(norm) or never:
            return math.inf
        worst = max(worst, norm)
    return worst


#: a task is reported limited below this fraction of its reference rate
LIMITED_RATIO = 0.9


def commanded_rates(state: StepState, batch: TaskBatch) -> np.ndarray:
    """Every task row's rate (its units per s) under the last commands ``[qdot; v]``:
    the rows' Jacobians at their last evaluation times the commanded system velocity
    (index it with ``batch.slices[k]`` for task ``k``)."""
    return np.asarray(batch.J @ np.concatenate((state.qdot_cmd, state.v_cmd)))


def limited(
    state: StepState, blend: ActionBlend, batch: TaskBatch, rows: RowValues | None = None
) -> dict[str, dict[str, Any]]:
    """The current action's equality and velocity tasks (goals, operator commands)
    moved at less than :data:`LIMITED_RATIO` of their reference by the last
    commands: ``{task: {"ratio": the commanded rate's share of the reference
    (projection), "by": [active inequality tasks above it]}}``.
    An empty ``by``: no task above held it back, but the velocity limits or its
    own level's conditioning (damped near a singular direction of the arm).
    ``rows``: the batch's values to read (default: the batch's arrays now)."""
    action = blend.action
    if action is None or blend.stopped:
        return {}
    if rows is None:
        rows = RowValues.of(state, batch)
    tasks = blend.actions.tasks
    index, slices = batch.index, batch.slices
    activation, reference, rate, status, t_rec = rows.activation, rows.reference, rows.rate, rows.status, rows.t_rec
    out: dict[str, dict[str, Any]] = {}
    active_above: list[str] = []
    for name in blend.actions.tasks_of(action):
        k = index[name]
        s = slices[k]
        if tasks[name].KIND == "inequality":
            if any(activation[s]):
                active_above.append(name)
        elif status[k] == 0 and not math.isnan(t_rec[k]):
            ref = reference[s]
            ref_norm = _norm(ref)
            if ref_norm > 1e-9:
                ratio = _dot(rate[s], ref) / (ref_norm * ref_norm)
                if ratio < LIMITED_RATIO:
                    out[name] = {"ratio": ratio, "by": list(active_above)}
    return out


def status(state: StepState, blend: ActionBlend, batch: TaskBatch) -> ControllerStatus:
    """The :data:`STATUS_KEYS` fields of the telemetry."""
    t = state.t
    action = blend.action
    return {
        "t": t,
        "action": action,
        "stopped": blend.stopped,
        "transition_progress": blend.progress(t),
        "fault": state.fault,
        "fault_reason": state.fault_reason if state.fault else "",
        "convergence": None if action is None else _json_float(convergence(blend.actions, batch, action)),
    }


@dataclass(slots=True)
class TelemetrySnapshot:
    """What the telemetry reports, taken at one step (:meth:`take`): the step
    state and the action blend as they were (shallow copies: the controller replaces
    their arrays and never writes into them) and the batch's row values then.
    ``batch`` is read for its layout only (task slots and row slices)."""

    state: StepState
    blend: ActionBlend
    batch: TaskBatch
    rows: RowValues
    filtered_velocity: np.ndarray | None
    compensation: bool

    @classmethod
    def take(
        cls,
        state: StepState,
        blend: ActionBlend,
        batch: TaskBatch,
        velocity_filter: FirstOrderLowPass,
        compensation: bool,
    ) -> TelemetrySnapshot:
        """The controller's report as it is now."""
        rows = RowValues.of(state, batch)
        return cls(copy.copy(state), copy.copy(blend), batch, rows, velocity_filter.value, compensation)

    def message(self) -> dict[str, Any]:
        """The JSON-able telemetry (lists of floats, strings, bools). Every task
        stacked at least once has a record: its last stacking time, a_p at the
        snapshot's time, activation at its last stacking (including a_p then),
        error, reference, commanded rate and the note of an idle task."""
        state, blend, batch, rows = self.state, self.blend, self.batch, self.rows
        t = state.t
        activation, error, reference, rate = rows.activation, rows.error, rows.reference, rows.rate
        t_rec, ap_rec, status_codes = rows.t_rec, rows.ap_rec, rows.status
        index, slices = batch.index, batch.slices
        tasks = {}
        for name, a_p in zip(blend.names, blend.factors_at(t).tolist()):
            k = index[name]
            t_k = t_rec[k]
            if math.isnan(t_k):
                continue
            s = slices[k]
            a = activation[s]
            ap_then = ap_rec[k]
            if ap_then < 1.0:
                a = [x * ap_then for x in a]  # the float64 product, as numpy's a * ap
            code = status_codes[k]
            tasks[name] = {
                "t": t_k,
                "a_p": a_p,
                "activation": a,
                "error": error[s],
                "reference": reference[s],
                "commanded_rate": rate[s],
                "note": IDLE_NOTES.get(code, "") if code > 0 else "",
            }
        v_f = self.filtered_velocity
        action = blend.action
        return {
            "t": t,
            "action": action,
            "previous_action": blend.previous_action,
            "transition_progress": blend.progress(t),
            "stopped": blend.stopped,
            "fault": state.fault,
            "fault_reason": state.fault_reason if state.fault else "",
            "fault_count": state.fault_count,
            "compensation": self.compensation,
            "vehicle_reference": state.v_cmd.tolist(),
            "joint_reference": state.qdot_cmd.tolist(),
            "filtered_velocity": None if v_f is None else v_f.tolist(),
            "tpik2_vehicle_velocity": state.v_tpik2.tolist(),
            "tpik1_velocity_source": state.source1,
            "tpik2_velocity_source": state.source2,
            "convergence": None if action is None else _json_float(convergence(blend.actions, batch, action, rows)),
            "tasks": tasks,
            "limited": limited(state, blend, batch, rows),
        }


def _dot(a: Iterable[float], b: Iterable[float]) -> float:
    """Sum of products in index order (numpy's dot of short float64 vectors)."""
    total = 0.0
    for x, y in zip(a, b):
        total += x * y
    return total


def _norm(v: Sequence[float]) -> float:
    """Euclidean norm, its squares summed in index order."""
    total = 0.0
    for x in v:
        total += x * x
    return math.sqrt(total)


def _json_float(x: float) -> float | None:
    return x if math.isfinite(x) else None
