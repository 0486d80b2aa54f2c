"""Run one mission end to end: :func:`run_mission` (no terminal output).

It loads the mission (and the HAL config for field runs), builds the KCL model,
actions and controller, the backend (the simulator unless one is given), the
blackboard and the run log, then hands everything to
:class:`mission.runtime.supervisor.Supervisor`. ``maris sim``, ``maris run``,
the dry-run benchmark, the Monte Carlo campaigns and the replay all call it,
with three records (:mod:`mission.runtime.options`): what to run
(:class:`RunTarget`), how (:class:`RunOptions`) and what to call back
(:class:`RunHooks`).
"""

from __future__ import annotations

import dataclasses
import time
from collections.abc import Mapping
from dataclasses import asdict, is_dataclass, replace
from pathlib import Path
from typing import Any

import numpy as np

import hal
import sim_backend
from behaviours.context import MissionBlackboard
from hal.check import config_entries
from hal.config import HalConfig, load_hal_config
from kcl.actions import DEFAULT_ACTIONS, load_actions
from kcl.controller import ControllerConfig, MeasuredState, UvmsController
from kcl.model import DEFAULT_URDF, UvmsModel
from mission.compiler import compile_abort, compile_mission
from mission.loader import load_mission
from mission.logs.runmeta import result_metadata, run_metadata, time_base
from mission.logs.writer import RunLogWriter
from mission.runtime.inputrecord import InputRecord, input_recorder
from mission.runtime.operator import CommandQueue, Commands, ScriptedOperator
from mission.runtime.options import DEFAULT_SCENARIO, RunHooks, RunOptions, RunTarget
from mission.runtime.pylog import LogCapture
from mission.runtime.result import SupervisorOptions
from mission.runtime.supervisor import RunResult, Supervisor
from mission.spec import Mission

__all__ = ["DEFAULT_SCENARIO", "RunHooks", "RunOptions", "RunTarget", "default_log_path", "run_mission"]


def default_log_path(mission_path: str | Path, runs_dir: str | Path = "runs") -> Path:
    """``runs/<mission stem>-<UTC timestamp>.mcap``."""
    stamp = time.strftime("%Y%m%d-%H%M%S", time.gmtime())
    return Path(runs_dir) / f"{Path(mission_path).stem}-{stamp}.mcap"


_ND, _F64 = np.ndarray, np.dtype(np.float64)
_measured = MeasuredState.of


def measured_state(nav: Any, js: Any, t: float) -> MeasuredState:
    """KCL measurement from the device readings: joints (rad), ``eta`` = world NED
    position + roll/pitch/yaw, body velocity [u v w p q r] (None without DVL),
    altitude above the bottom (m, None if unknown)."""
    pos, att, q, v = nav.position, nav.attitude, js.position, nav.body_velocity
    # float64 arrays (the usual readings) as they are: what np.asarray(x, dtype=float) returns
    if type(pos) is not _ND or pos.dtype is not _F64:
        pos = np.asarray(pos, dtype=float)
    if type(att) is not _ND or att.dtype is not _F64:
        att = np.asarray(att, dtype=float)
    if type(q) is not _ND or q.dtype is not _F64:
        q = np.asarray(q, dtype=float)
    if v is not None and (type(v) is not _ND or v.dtype is not _F64):
        v = np.asarray(v, dtype=float)
    return _measured(q, np.concatenate((pos, att)), v, t, nav.altitude)


def _jsonable(obj: Any) -> Any:
    if is_dataclass(obj) and not isinstance(obj, type):
        return {k: _jsonable(v) for k, v in asdict(obj).items()}
    if isinstance(obj, dict):
        return {str(k): _jsonable(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [_jsonable(v) for v in obj]
    if isinstance(obj, (str, int, float, bool)) or obj is None:
        return obj
    if isinstance(obj, np.ndarray):
        return obj.tolist()
    return str(obj)


def _read_text(path: Any) -> str | None:
    try:
        return Path(path).read_text(encoding="utf-8")
    except (OSError, TypeError, UnicodeDecodeError):
        return None


def _sim_hal_config() -> tuple[HalConfig | None, Path | None]:
    """The simulator's HAL config (``hal/configs/sim.yaml``): dry runs validate
    the mission against it, as field runs do against theirs."""
    path = Path(hal.__file__).parent / "configs" / "sim.yaml"
    if not path.exists():
        return None, None
    return load_hal_config(path), path


def run_mission(target: RunTarget, options: RunOptions | None = None, hooks: RunHooks | None = None) -> RunResult:
    """Run ``target`` once, as ``options`` say, calling ``hooks``; return its :class:`RunResult`.

    The mission's lint warnings become ``lint`` events (shown in the summary);
    ``options.strict`` refuses a mission that has any (ConfigError). With a log,
    every input of the supervisor is recorded in it by the registered input
    recorder (:mod:`mission.runtime.inputrecord`: import :mod:`mission.replay.record`),
    so ``maris log replay`` can run it again; without ``record_inputs`` the log's
    ``maris.run`` metadata says ``input_record: no``. Raises
    :class:`maris_common.yamlsrc.ConfigError` for bad mission/scenario files;
    field faults and software errors end the run (see ``RunResult.failure_cause``),
    they do not raise.
    """
    options = options or RunOptions()
    hooks = hooks or RunHooks()
    log_path = options.log_path
    recorder = None
    if log_path is not None and options.record_inputs:  # every input the supervisor consumes, for `maris log replay`
        recorder = input_recorder()
        if recorder is None:
            raise RuntimeError(
                "run_mission: a log with the input record needs the recorder: import mission.replay.record "
                "(it registers itself), or run with RunOptions(record_inputs=False)"
            )
    backend = target.backend
    hal_config, hal_config_path = target.hal_config, target.hal_config_path
    if hal_config is None and backend is None:
        hal_config, hal_config_path = _sim_hal_config()
    mission_path: str | Path
    scen = None
    if backend is None:  # a dry run: the scenario may name the rig (mission.platform)
        scen = sim_backend.load_scenario(target.scenario or DEFAULT_SCENARIO, _overrides(target.overrides))
    if isinstance(target.mission, Mission):
        mission, mission_path = target.mission, target.mission.file
    else:
        mission_path = target.mission
        mission = load_mission(mission_path, hal_config, strict=options.strict, scenario=scen)
    model = UvmsModel.load(urdf=mission.model)
    actions = load_actions(mission.actions_file, model)
    if backend is None:
        assert scen is not None  # loaded above for a dry run
        backend = sim_backend.SimBackend(scen, target.seed, realtime=options.realtime, model=model)
    config = ControllerConfig(
        vehicle_rate_hz=mission.rates.vehicle_hz,
        arm_rate_hz=mission.rates.arm_hz,
        filter_cutoff_rad_s=options.filter_cutoff,
        compensation=options.compensation,
        actuated_dofs=tuple(backend.devices.vehicle.actuated_dofs),
        **(options.controller_options or {}),
    )
    controller = UvmsController(model, actions, config)
    blackboard = MissionBlackboard.for_mission(mission)

    if not mission.uses_operator:  # no teleop node: the operator inputs are not polled, recorded or fed
        backend.devices = dataclasses.replace(backend.devices, operators={})
    # what feeds the operator inputs pushes into the devices themselves; the record wraps their reads
    operators = dict(backend.devices.operators)
    if hooks.live is not None and "foxglove" in operators:
        hooks.live.attach_input(operators["foxglove"])
    for feed in hooks.input_feeds:
        feed(operators)
    recording: InputRecord | None = None
    if recorder is not None:
        recording = recorder(backend, mission_path)  # log attached below
        backend = recording.backend
    log = None
    if log_path is not None:
        offset_ns, time_meta = time_base(scen is not None, backend.clock.now())
        log = RunLogWriter(log_path, live=hooks.live, time_offset_ns=offset_ns)
        log.metadata(
            "maris.run",
            run_metadata(
                mission_name=mission.name,
                mission_path=str(mission_path),
                scenario=None if scen is None else scen.name,
                seed=target.seed if scen is not None else None,
                hal_config=None if hal_config_path is None or scen is not None else str(hal_config_path),
                time_meta=time_meta,
                input_record=recording is not None,
            ),
        )
    queue: Commands = hooks.commands or CommandQueue()
    if recording is not None:
        recording.attach(log)
        queue = recording.record_commands(queue)
    polls = list(hooks.pollers)
    script = list(hooks.operator_script)
    if script:
        polls.append(ScriptedOperator(queue, script).poll)
    live = hooks.live
    if live is not None:  # the live server's notices go to the run log, not the terminal
        polls.append(lambda _now: live.forward_notices(supervisor.events))
    sup_options = options.supervisor
    if isinstance(hal_config, HalConfig) and not (sup_options and sup_options.config_entries):
        # the preflight names the config entry of a device it has not heard from
        sup_options = replace(sup_options or SupervisorOptions(), config_entries=config_entries(hal_config))
    supervisor = Supervisor(
        backend,
        controller,
        rates=mission.rates,
        safety=mission.safety,
        make_tree=lambda ctx: compile_mission(mission, ctx),
        make_abort_tree=(lambda ctx: compile_abort(mission, ctx)) if mission.abort is not None else None,
        measure=measured_state,
        blackboard=blackboard,
        log=log,
        model=model,
        mission=mission,
        options=sup_options,
        commands=queue,
        pollers=polls,
        on_progress=hooks.on_progress,
        on_event=hooks.on_event,
        log_capture=recording.log_capture if recording is not None else LogCapture,
    )
    try:
        if hooks.on_supervisor is not None:
            try:
                hooks.on_supervisor(supervisor)
            except Exception:
                if log is not None and log_path is not None:  # nothing ran: leave no empty log behind
                    log.close()
                    Path(log_path).unlink(missing_ok=True)
                raise
        if log is not None:
            t = backend.clock.now()
            log.write(
                "/run/config",
                t,
                {
                    "mission_path": str(mission_path),
                    "mission_name": mission.name,
                    "scenario": None if scen is None else scen.name,
                    "seed": target.seed if scen is not None else None,
                    "realtime": bool(options.realtime or getattr(backend, "realtime", False)),
                    "rates_hz": _jsonable(mission.rates),
                    "controller": _jsonable(config),
                    "safety": _jsonable(mission.safety),
                    "overrides": _jsonable(_overrides(target.overrides) or {}),
                    "supervisor": _jsonable(supervisor.options),
                    "joint_names": list(backend.devices.arm.joint_names),
                    "actuated_dofs": list(backend.devices.vehicle.actuated_dofs),
                },
            )
            sources = [
                ("mission", mission_path),
                ("scenario", None if scen is None else scen.source),
                ("hal_config", hal_config_path),
                ("actions", mission.actions_file or DEFAULT_ACTIONS),
                ("model", mission.model or DEFAULT_URDF),
            ]
            for role, path in sources:
                text = _read_text(path) if path is not None else None
                if text is not None:
                    log.write("/run/source", t, {"role": role, "path": str(path), "text": text})
            log.flush()
        for warning in mission.warnings:
            supervisor.events.emit("lint", f"mission check: {warning}", level="warning", summary=True)
        result = supervisor.run()  # opens the backend; closed below whatever happens
        if log is not None:
            log.metadata("maris.result", result_metadata(result))
        return result
    finally:
        try:
            backend.close()
        finally:
            if log is not None:
                log.close()


def _overrides(overrides: Mapping[str, Any] | None) -> dict[str, Any] | None:
    """The scenario overrides as the scenario loader and the log take them (a dict)."""
    return None if overrides is None else dict(overrides)
