"""One campaign run: the function the workers execute.

:func:`run_one` calls the runtime's headless ``mission.runtime.api.run_mission``
with the run's scenario, seed, overrides and controller options, classifies the
result (:mod:`mission.campaign.classify`) and keeps the metrics that depend
only on the seed (wall-clock figures are dropped so tables repeat exactly).

With ``"oscillation"`` in ``RunSpec.measure``, :class:`ArmReferenceRecorder`
records every joint reference velocity the KCL produces (full arm rate, through
run_mission's ``on_supervisor`` hook) with the action active at that time (from
``on_progress``, tree rate) and, on the simulator, the *actual* motion at the
same instants: the vehicle's true angular rates and the tool's true world
position. The oscillation during the ``grasp`` action is measured on each
(:mod:`mission.campaign.oscillation`): metrics ``grasp_osc_rms_rad_s`` /
``grasp_osc_rms_10hz_rad_s`` (joint references above 1 / 10 Hz),
``grasp_vehicle_rate_osc_rad_s`` (true angular rate above 1 Hz, RMS over p, q, r)
and ``grasp_tool_osc_m`` (true tool position above 1 Hz, RMS over x, y, z), and
the same two above 8 Hz (``..._8hz_...``: the band the KCL's 50 rad/s filter acts on).
The ``on_progress`` hook also enforces the run's wall-clock limit
(:mod:`mission.campaign.deadline`).
"""

from __future__ import annotations

import math
import os
from collections.abc import Mapping
from typing import Any

import numpy as np

import mission.replay.record  # noqa: F401 - registers the input record of the runs' logs
from kcl.actions import load_actions
from kcl.controller import ControllerConfig, UvmsController
from kcl.model import UvmsModel
from maris_common.yamlsrc import ConfigError, ConfigIssue, Mark
from mission.campaign.attempts import attempts_of_run
from mission.campaign.classify import classify
from mission.campaign.deadline import check_deadline
from mission.campaign.oscillation import action_segments, segments_rms
from mission.campaign.plan import RunSpec
from mission.campaign.records import RunRecord
from mission.loader import load_mission
from mission.runtime.api import run_mission
from mission.runtime.options import NO_FILTER_CUTOFF_RAD_S, RunHooks, RunOptions, RunTarget
from mission.runtime.supervisor import Supervisor
from sim_backend import SimBackend, load_scenario

#: metrics of the runtime that depend on the machine, not the seed (matched anywhere in the name)
_WALL_MARKS = ("wall", "realtime_factor")

#: campaign controller option -> field of :class:`mission.runtime.options.RunOptions`
_CONTROLLER_FIELDS = {"compensation": "compensation", "filter_cutoff_rad_s": "filter_cutoff"}


def run_options(controller: Mapping[str, Any], log_path: str | None = None) -> RunOptions:
    """The run's options from the campaign's ``controller.*`` options; a disabled filter
    (``None`` or ``.inf``) becomes :data:`mission.runtime.options.NO_FILTER_CUTOFF_RAD_S`."""
    fields: dict[str, Any] = {}
    for key, value in controller.items():
        if key == "filter_cutoff_rad_s" and (value is None or math.isinf(value)):
            value = NO_FILTER_CUTOFF_RAD_S
        fields[_CONTROLLER_FIELDS[key]] = value
    return RunOptions(log_path=log_path, **fields)


def deterministic_metrics(metrics: dict[str, Any]) -> dict[str, float]:
    """Flat ``name -> float`` copy of the numeric run metrics (nested names dotted),
    minus wall-clock ones."""
    out: dict[str, float] = {}

    def walk(prefix: str, value: Any) -> None:
        if any(m in prefix for m in _WALL_MARKS):
            return
        if isinstance(value, dict):
            for k, v in value.items():
                walk(f"{prefix}.{k}" if prefix else str(k), v)
        elif isinstance(value, bool):
            out[prefix] = float(value)
        elif isinstance(value, (int, float)):
            out[prefix] = float(value)

    walk("", metrics or {})
    return out


class ArmReferenceRecorder:
    """Joint reference velocities (rad/s) of every KCL arm step, with their time
    (backend clock, s) and the KCL action active then."""

    #: the KCL action during which the actual motion is sampled (the truth costs a pose per step)
    truth_action = "grasp"

    def __init__(self) -> None:
        self.t: list[float] = []
        self.qdot: list[Any] = []
        self.action: list[str | None] = []
        self.rates: list[Any] = []  # true vehicle angular rates (3,) rad/s, or None
        self.tool: list[Any] = []  # true tool position (3,) m world, or None
        self._current: str | None = None

    def attach(self, supervisor: Supervisor) -> None:
        """``on_supervisor`` hook: wrap the controller's ``arm_step`` (this instance only)."""
        controller = supervisor.controller
        inner = controller.arm_step
        backend = supervisor.backend
        vehicle = getattr(backend, "vehicle", None)
        tool_pose = getattr(backend, "tool_pose", None)  # simulator only, as the vehicle's truth

        def arm_step(meas: Any, t: float) -> Any:
            out = inner(meas, t)
            self.t.append(float(t))
            self.qdot.append(out)
            self.action.append(self._current)
            if vehicle is not None and tool_pose is not None and self._current == self.truth_action:
                self.rates.append(vehicle.nu[3:6].copy())
                self.tool.append(tool_pose()[:3, 3].copy())
            else:
                self.rates.append(None)
                self.tool.append(None)
            return out

        controller.arm_step = arm_step

    def on_progress(self, _elapsed: float, _state: str, action: str | None, _leaf: str | None) -> None:
        """``on_progress`` hook (tree rate): remember the active action."""
        self._current = action

    def oscillation(self, action: str = "grasp", cutoff_hz: float = 1.0, series: str = "qdot") -> float:
        """High-passed RMS of a recorded series while ``action`` ran; NaN if it never
        did (or, for the truth, on a backend without one). ``series``: ``qdot`` (joint
        references, rad/s), ``rates`` (true vehicle angular rates, rad/s), ``tool``
        (true tool position, m)."""
        if not self.t:
            return float("nan")
        t = np.asarray(self.t)
        if series == "qdot":
            q = np.asarray(self.qdot, dtype=float).reshape(len(self.t), -1)
        else:
            rows = getattr(self, series)
            if all(r is None for r in rows):
                return float("nan")
            q = np.array([np.full(3, np.nan) if r is None else r for r in rows], dtype=float)
        change = [i for i in range(len(self.action)) if i == 0 or self.action[i] != self.action[i - 1]]
        segs = action_segments(t[change], [self.action[i] for i in change], t, q, action)
        return segments_rms(segs, cutoff_hz)


def run_one(spec: RunSpec) -> RunRecord:
    """Run the mission once as planned and return its classified record."""
    recorder = ArmReferenceRecorder() if "oscillation" in spec.measure else None

    def on_progress(elapsed: float, state: str, action: str | None, leaf: str | None) -> None:
        check_deadline()  # the wall-clock limit (executor), checked at every tree tick
        if recorder is not None:
            recorder.on_progress(elapsed, state, action, leaf)

    if spec.log_path is not None:
        os.makedirs(os.path.dirname(os.path.abspath(spec.log_path)), exist_ok=True)
    result = run_mission(
        RunTarget(spec.mission_path, scenario=spec.scenario, seed=spec.seed, overrides=dict(spec.overrides)),
        run_options(spec.controller, spec.log_path),
        RunHooks(on_progress=on_progress, on_supervisor=recorder.attach if recorder is not None else None),
    )
    check_deadline()  # the supervisor ends a run whose hook raised as "internal error": record it as a timeout
    metrics = deterministic_metrics(getattr(result, "metrics", {}) or {})
    if recorder is not None:
        metrics["grasp_osc_rms_rad_s"] = recorder.oscillation(cutoff_hz=1.0)
        metrics["grasp_osc_rms_10hz_rad_s"] = recorder.oscillation(cutoff_hz=10.0)
        metrics["grasp_vehicle_rate_osc_rad_s"] = recorder.oscillation(cutoff_hz=1.0, series="rates")
        metrics["grasp_tool_osc_m"] = recorder.oscillation(cutoff_hz=1.0, series="tool")
        # above the KCL filter's 50 rad/s (8 Hz) corner: the band the filter acts on
        metrics["grasp_vehicle_rate_osc_8hz_rad_s"] = recorder.oscillation(cutoff_hz=8.0, series="rates")
        metrics["grasp_tool_osc_8hz_m"] = recorder.oscillation(cutoff_hz=8.0, series="tool")
    return record_of(spec, result, metrics)


def record_of(spec: RunSpec, result: Any, metrics: dict[str, float]) -> RunRecord:
    """The classified record of ``spec``'s run (its :class:`RunResult` ``result`` and
    the ``metrics`` to keep): outcome, grasp attempts (Table I's unit), the log's path."""
    t_end = float(metrics.get("t0", 0.0)) + float(result.duration_s)
    attempts = [a.to_dict() for a in attempts_of_run(getattr(result, "events", None) or [], t_end)]
    outcome = classify(result)
    if outcome == "grasp_missed" and attempts and all(a["outcome"] == "not_detected" for a in attempts):
        outcome = "not_detected"  # no attempt ever had a detection to reach for
    return RunRecord(
        index=spec.index,
        seed=spec.seed,
        outcome=outcome,
        duration_s=float(result.duration_s),
        failure_cause=result.failure_cause,
        grasp=result.grasp,
        metrics=metrics,
        log_path=spec.log_path,
        attempts=attempts,
    )


def warm_up(spec: RunSpec) -> None:
    """Load (first time on a machine: compile) the compiled kernels that runs like
    ``spec`` use, in this process: the KCL's (a controller built once) and the
    simulator's (a backend of the spec's scenario built once). A local campaign
    calls it before it forks its worker processes, which then start with
    everything loaded instead of each loading it at its first run. Any error is
    left for the runs to report."""
    try:
        model = UvmsModel.load()
        UvmsController(model, load_actions(None, model), ControllerConfig())
        SimBackend(load_scenario(spec.scenario, dict(spec.overrides) or None), spec.seed, model=model)
    except Exception:  # noqa: BLE001 - a bad scenario or mission: the runs themselves say what is wrong
        pass


def check_inputs(mission_path: str, scenario: str, settings: Any, issues: list | None = None) -> None:
    """Load the mission and the scenario with its overrides once, before any run,
    so bad input is one clear ConfigError instead of N failed runs. Override
    problems are re-labelled with their ``--set`` position; ``issues`` (e.g. from
    parsing the ``--set`` options) are reported together with the others."""
    issues = list(issues or [])
    scen = None
    try:
        scen = load_scenario(scenario, settings.scenario or None)
    except ConfigError as exc:
        order = list(settings.scenario)
        for issue in exc.issues:
            key = issue.path[0] if issue.path else None
            if issue.mark.file == "<override>" and key in order:
                issue = ConfigIssue(
                    Mark("--set", settings.positions.get(key, order.index(key) + 1), 1), issue.path, issue.message
                )
            issues.append(issue)
    if not os.path.isfile(mission_path):
        issues.append(ConfigIssue(Mark(mission_path, 1, 1), (), "mission file not found"))
    else:
        try:  # with the scenario: the rig it names (mission.platform)
            load_mission(mission_path, scenario=scen)
        except ConfigError as exc:
            issues += exc.issues
    if issues:
        raise ConfigError(issues)
