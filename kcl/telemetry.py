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

:func:`status` gives the few of those fields the mission tree reads at every
tick (:data:`STATUS_KEYS`, the same values) without building the whole snapshot.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any, TypedDict

import numpy as np

from kcl.actions import ActionSet
from kcl.blend import ActionBlend
from kcl.filters import FirstOrderLowPass
from kcl.tasks.batch import TaskBatch


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


def convergence(actions: ActionSet, batch: TaskBatch, action: str | None) -> float:
    """Largest error norm among the goal tasks of ``action`` (goal tasks are its
    equality tasks unless the file says ``goal: false``), from their last
    evaluation: e.g. < 0.02 means "posture reached" for ``transport`` (rad) or
    "tool at the grasp frame" for ``grasp`` (m, rad). ``inf`` if one of them has
    not run yet or has no target; 0 without an action."""
    if action is None:
        return 0.0
    worst = 0.0
    for name in actions.tasks_of(action):
        if not actions.tasks[name].is_goal:
            continue
        norm = batch.error_norm(batch.index[name])
        if math.isnan(norm) or math.isnan(batch.t_rec[batch.index[name]]):
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
    state: StepState, blend: ActionBlend, batch: TaskBatch, rates: np.ndarray | None = None
) -> dict[str, dict[str, Any]]:
    """The current action's equality and velocity tasks (goals, operator commands)
    moved at less than :data:`LIMITED_RATIO` of their reference by the last
    commands: ``{task: {"ratio": the commanded rate's share of the reference
    (projection), "by": [active inequality tasks above it]}}``.
    An empty ``by``: no task above held it back, but the velocity limits or its
    own level's conditioning (damped near a singular direction of the arm).
    ``rates``: :func:`commanded_rates`, when the caller has them."""
    action = blend.action
    if action is None or blend.stopped:
        return {}
    if rates is None:
        rates = commanded_rates(state, batch)
    tasks = blend.actions.tasks
    index, slices, status, t_rec, XD = batch.index, batch.slices, batch.status, batch.t_rec, batch.XD
    activations = batch.A.tolist()
    out: dict[str, dict[str, Any]] = {}
    active_above: list[str] = []
    for name in blend.actions.tasks_of(action):
        k = index[name]
        s = slices[k]
        if tasks[name].KIND == "inequality":
            if any(activations[s]):
                active_above.append(name)
        elif status[k] == 0 and not math.isnan(t_rec[k]):
            ref = XD[s]
            ref_norm = math.sqrt(ref.dot(ref))  # np.linalg.norm of a vector: the same operations
            if ref_norm > 1e-9:
                ratio = float(rates[s].dot(ref)) / (ref_norm * ref_norm)
                if ratio < LIMITED_RATIO:
                    out[name] = {"ratio": ratio, "by": list(active_above)}
    return out


def status(state: StepState, blend: ActionBlend, batch: TaskBatch) -> ControllerStatus:
    """The :data:`STATUS_KEYS` fields of :func:`telemetry`."""
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


def telemetry(
    state: StepState, blend: ActionBlend, batch: TaskBatch, velocity_filter: FirstOrderLowPass, compensation: bool
) -> dict[str, Any]:
    """JSON-able snapshot for the log (lists of floats, strings, bools)."""
    t = state.t
    factors = blend.factors_at(t).tolist()
    rates = commanded_rates(state, batch)
    rate_values = rates.tolist()
    records = batch.records()
    index, slices = batch.index, batch.slices
    tasks = {}
    for name, a_p in zip(blend.names, factors):
        k = index[name]
        rec = records[k]
        if rec is None:
            continue
        tasks[name] = {
            "t": rec.t,
            "a_p": a_p,
            "activation": rec.activation,
            "error": rec.error,
            "reference": rec.reference,
            "commanded_rate": rate_values[slices[k]],
            "note": rec.note,
        }
    v_f = velocity_filter.value
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
        "compensation": compensation,
        "vehicle_reference": state.v_cmd.tolist(),
        "joint_reference": state.qdot_cmd.tolist(),
        "filtered_velocity": None if v_f is None else v_f.tolist(),
        "tpik2_vehicle_velocity": state.v_tpik2.tolist(),
        "tpik1_velocity_source": state.source1,
        "tpik2_velocity_source": state.source2,
        "convergence": None if action is None else _json_float(convergence(blend.actions, batch, action)),
        "tasks": tasks,
        "limited": limited(state, blend, batch, rates),
    }


def _json_float(x: float) -> float | None:
    return x if math.isfinite(x) else None
