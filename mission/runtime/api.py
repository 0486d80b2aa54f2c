"""Run one mission end to end: :func:`run_mission` (no terminal output).

It loads the mission (and the HAL config for field runs), builds the KCL model,
actions and controller, the backend (the simulator unless one is given), the
blackboard and the run log, then hands everything to
:class:`mission.runtime.supervisor.Supervisor`. ``maris sim``, ``maris run``,
the dry-run benchmark and the Monte Carlo campaigns all call it.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Iterable
from dataclasses import asdict, is_dataclass
from pathlib import Path
from typing import Any

import numpy as np

from mission.runtime.context import Event
from mission.runtime.operator import CommandQueue, ScriptedOperator
from mission.runtime.supervisor import RunResult, Supervisor, SupervisorOptions

#: Scenario used when none is named: the fixed, repeatable pool setting meant for
#: dry runs (pipe and start pose fixed; the seed still drives every noise stream).
#: Randomized settings (``pool_clear``, ``pool_turbid``...) are for campaigns.
DEFAULT_SCENARIO = "pool_fixed"


def default_log_path(mission_path: str | Path, runs_dir: str | Path = "runs") -> Path:
    """``runs/<mission stem>-<UTC timestamp>.mcap``."""
    stamp = time.strftime("%Y%m%d-%H%M%S", time.gmtime())
    return Path(runs_dir) / f"{Path(mission_path).stem}-{stamp}.mcap"


def measured_state(nav: Any, js: Any, t: float) -> Any:
    """KCL measurement from the device readings: joints (rad), ``eta`` = world NED
    position + roll/pitch/yaw, body velocity [u v w p q r] (None without DVL),
    altitude above the bottom (m, None if unknown)."""
    cls = _MEASURED_STATE
    if not cls:  # imported once (not at module import: kcl is heavy), not every step
        from kcl.controller import MeasuredState

        cls.append(MeasuredState.of)
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
    return cls[0](q, np.concatenate((pos, att)), v, t, nav.altitude)


_MEASURED_STATE: list = []
_ND, _F64 = np.ndarray, np.dtype(np.float64)


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


def _sim_hal_config() -> tuple[Any, Path | None]:
    """The simulator's HAL config (``hal/configs/sim.yaml``): dry runs validate
    the mission against it, as field runs do against theirs."""
    import hal
    from hal.config import load_hal_config

    path = Path(hal.__file__).parent / "configs" / "sim.yaml"
    if not path.exists():
        return None, None
    return load_hal_config(path), path


def run_mission(
    mission_path: str | Path,
    *,
    scenario: str | Path | None = None,
    seed: int = 0,
    overrides: dict[str, Any] | None = None,
    log_path: str | Path | None = None,
    compensation: bool = True,
    filter_cutoff: float = 50.0,
    realtime: bool = False,
    backend: Any = None,
    hal_config: Any = None,
    hal_config_path: str | Path | None = None,
    operator_script: Iterable[tuple[float, str]] = (),
    commands: CommandQueue | None = None,
    pollers: list[Callable[[float], None]] | None = None,
    options: SupervisorOptions | None = None,
    on_progress: Callable[[float, str, str | None, str | None], None] | None = None,
    on_event: Callable[[Event], None] | None = None,
    on_supervisor: Callable[[Supervisor], None] | None = None,
    live: Any = None,
    strict: bool = False,
    controller_options: dict[str, Any] | None = None,
    record_inputs: bool = True,
) -> RunResult:
    """Run ``mission_path`` once and return its :class:`RunResult`.

    Simulator (default): ``scenario`` (name or path, default
    :data:`DEFAULT_SCENARIO`), ``seed``, ``overrides`` (dotted scenario keys).
    Field run: pass ``backend`` (built from ``hal_config``). ``log_path=None``
    writes no log. ``operator_script``: ``[(t_s, "pause"|"resume"|"abort"), ...]``
    on the backend clock. ``live``: a :class:`mission.logs.live.LiveServer` that
    also gets every log message (needs ``log_path``). The mission's lint
    warnings become ``lint`` events (shown in the summary); ``strict`` refuses
    a mission that has any (ConfigError). ``mission_path`` may also be an
    already loaded :class:`mission.spec.Mission` (a replay rebuilds it from a
    log). ``controller_options``: further :class:`kcl.controller.ControllerConfig`
    fields (e.g. ``{"lam": 0.01}``). With a log, every input of the supervisor is
    recorded in it (:mod:`mission.replay.record`), so ``maris log replay`` can
    run it again (``record_inputs=False``: not, as ``maris sim --no-input-record``; the
    log's ``maris.run`` metadata says ``input_record: no``). Raises
    :class:`maris_common.yamlsrc.ConfigError` for bad mission/scenario files;
    field faults and software errors end the run (see ``RunResult.failure_cause``),
    they do not raise.
    """
    from behaviours.context import MissionBlackboard
    from kcl.actions import load_actions
    from kcl.controller import ControllerConfig, UvmsController
    from kcl.model import UvmsModel
    from mission.compiler import compile_abort, compile_mission
    from mission.loader import load_mission
    from mission.spec import Mission

    if hal_config is None and backend is None:
        hal_config, hal_config_path = _sim_hal_config()
    scen = None
    if backend is None:  # a dry run: the scenario may name the rig (mission.platform)
        from sim_backend import load_scenario

        scen = load_scenario(scenario or DEFAULT_SCENARIO, overrides)
    if isinstance(mission_path, Mission):
        mission, mission_path = mission_path, mission_path.file
    else:
        mission = load_mission(mission_path, hal_config, strict=strict, scenario=scen)
    model = UvmsModel.load(urdf=mission.model)
    actions = load_actions(mission.actions_file, model)
    if backend is None:
        from sim_backend import SimBackend

        assert scen is not None  # loaded above for a dry run
        backend = SimBackend(scen, seed, realtime=realtime, model=model)
    config = ControllerConfig(
        vehicle_rate_hz=mission.rates.vehicle_hz,
        arm_rate_hz=mission.rates.arm_hz,
        filter_cutoff_rad_s=filter_cutoff,
        compensation=compensation,
        actuated_dofs=tuple(backend.devices.vehicle.actuated_dofs),
        **(controller_options or {}),
    )
    controller = UvmsController(model, actions, config)
    blackboard = MissionBlackboard.for_mission(mission)

    recording = None
    if log_path is not None and record_inputs:  # every input the supervisor consumes, for `maris log replay`
        from mission.replay.record import RecordingBackend

        backend = recording = RecordingBackend(backend, mission_file=mission_path)  # log attached below
    log = None
    if log_path is not None:
        from mission.logs.runmeta import run_metadata, time_base
        from mission.logs.writer import RunLogWriter

        offset_ns, time_meta = time_base(scen is not None, backend.clock.now())
        log = RunLogWriter(log_path, live=live, time_offset_ns=offset_ns)
        log.metadata(
            "maris.run",
            run_metadata(
                mission_name=mission.name,
                mission_path=str(mission_path),
                scenario=None if scen is None else scen.name,
                seed=seed if scen is not None else None,
                hal_config=None if hal_config_path is None or scen is not None else str(hal_config_path),
                time_meta=time_meta,
                input_record=recording is not None,
            ),
        )
    queue = commands or CommandQueue()
    if recording is not None:
        from mission.replay.record import RecordingQueue

        recording.attach(log)
        queue = RecordingQueue(queue, recording)
    polls = list(pollers or [])
    script = list(operator_script)
    if script:
        polls.append(ScriptedOperator(queue, script).poll)
    if live is not None:  # the live server's notices go to the run log, not the terminal
        polls.append(lambda _now: live.forward_notices(supervisor.events))
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
        options=options,
        commands=queue,
        pollers=polls,
        on_progress=on_progress,
        on_event=on_event,
        **({"log_capture": recording.log_capture} if recording is not None else {}),
    )
    try:
        if on_supervisor is not None:
            try:
                on_supervisor(supervisor)
            except Exception:
                if log is not None:  # nothing ran: leave no empty log behind
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
                    "seed": seed if scen is not None else None,
                    "realtime": bool(realtime or getattr(backend, "realtime", False)),
                    "rates_hz": _jsonable(mission.rates),
                    "controller": _jsonable(config),
                    "safety": _jsonable(mission.safety),
                    "overrides": _jsonable(overrides or {}),
                    "supervisor": _jsonable(supervisor.options),
                    "joint_names": list(backend.devices.arm.joint_names),
                    "actuated_dofs": list(backend.devices.vehicle.actuated_dofs),
                },
            )
            from kcl.actions import DEFAULT_ACTIONS
            from kcl.model import DEFAULT_URDF

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
            from mission.logs.runmeta import result_metadata

            log.metadata("maris.result", result_metadata(result))
        return result
    finally:
        try:
            backend.close()
        finally:
            if log is not None:
                log.close()
