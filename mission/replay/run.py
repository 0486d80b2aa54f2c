"""``maris log replay`` as a function: :func:`replay_log` -> :class:`ReplayReport`.

Reads the log, rebuilds the run (:mod:`mission.replay.rebuild`), runs the
same :func:`mission.runtime.api.run_mission` against a
:class:`mission.replay.serve.ReplayBackend` (writing the replay's own log,
with its own input record), then compares the two logs
(:mod:`mission.replay.compare`). The replay stops with the run, or at the end
of the log (a log cut short replays up to its last complete step).
"""

from __future__ import annotations

import dataclasses
import tempfile
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any, NamedTuple

import mission.replay.record  # noqa: F401 - registers the input record: the replay's own log has one
from mission.replay.compare import Comparison, compare_logs
from mission.replay.rawlog import RawLog
from mission.replay.rebuild import setup_replay
from mission.replay.serve import EndOfLog, ReplayBackend, ReplayInputs
from mission.replay.whatif import summarize
from mission.runtime.api import RunHooks, RunTarget, run_mission
from mission.runtime.operator import OperatorCommand


class ReplayQueue:
    """The operator command queue of a replay: the logged commands, at their drains."""

    def __init__(self, backend: ReplayBackend) -> None:
        self._server = backend.server
        self._extra: list[OperatorCommand] = []

    def put(self, command: str, source: str) -> None:
        self._extra.append(OperatorCommand(command, source))

    def drain(self) -> list[OperatorCommand]:
        out = self._server.drain() + self._extra
        self._extra = []
        return out


class LogPair(NamedTuple):
    """The logged run and its replay, read."""

    original: RawLog
    replay: RawLog


@dataclass
class ReplayReport:
    log_path: Path
    #: True for an open-loop what-if (changed mission or controller setting).
    whatif: bool
    changes: list[str]
    notes: list[str]
    comparison: Comparison
    #: The logged run's outcome (None: the log was cut short before the end).
    logged_outcome: str | None
    #: The replay's outcome, or None when the log ended first.
    replay_outcome: str | None
    replay_cause: str | None
    #: Step at which the log ran out before the replay finished (None: the replay finished).
    ended_at_step: int | None
    log_truncated: bool
    steps: int
    #: Mission time replayed (s); wall time (s) of the supervisor's run (as ``benchmarks/dry_run.py``
    #: measures it), of loading the mission and models before it, and of the comparison.
    mission_s: float
    wall_s: float
    #: CPU time (s) of this process during the supervisor's run (less sensitive to other load).
    cpu_s: float
    setup_wall_s: float
    compare_wall_s: float
    replay_log: Path | None = None
    #: Open-loop what-if summary (:func:`mission.replay.whatif.summarize`), None for an exact replay.
    summary: dict | None = None
    #: Both logs, read, for plots.
    logs: LogPair | None = None

    @property
    def identical(self) -> bool:
        return self.comparison.identical


def replay_log(
    path: str | Path,
    *,
    mission: str | Path | None = None,
    settings: dict[str, Any] | None = None,
    out: str | Path | None = None,
    tolerance: float = 0.0,
    on_progress: Callable[[float, str, str | None, str | None], None] | None = None,
) -> ReplayReport:
    """Replay the run logged at ``path``; ``mission`` / ``settings`` make it a what-if.

    ``out``: keep the replay's own log there (default: a temporary file).
    Raises :class:`mission.logs.reader.LogError` (unreadable file),
    :class:`mission.replay.serve.NotReplayable` (no input record, or a changed
    base rate) and :class:`maris_common.yamlsrc.ConfigError` (invalid changed mission).
    """
    log = RawLog(path)
    inputs = ReplayInputs.from_log(log)
    whatif = mission is not None or bool(settings)
    with tempfile.TemporaryDirectory(prefix="maris-replay-") as tmp:
        work = Path(tmp)
        setup = setup_replay(log, inputs, work, mission_path=mission, settings=settings)
        out_path = Path(out) if out is not None else work / "replay.mcap"
        backend = ReplayBackend(inputs)
        ended_at: int | None = None
        result = None
        wall0 = time.perf_counter()
        try:
            result = run_mission(
                RunTarget(setup.mission, backend=backend, hal_config=setup.roles),
                dataclasses.replace(setup.options, log_path=out_path),
                RunHooks(commands=ReplayQueue(backend), on_progress=on_progress),
            )
        except EndOfLog as end:
            ended_at = end.step
        wall = time.perf_counter() - wall0
        loop_wall = (backend.wall_close - backend.wall_open) if backend.wall_open and backend.wall_close else wall
        loop_cpu = backend.cpu_close - backend.cpu_open
        c0 = time.perf_counter()
        replay = RawLog(out_path)
        complete = bool(log.messages("/run/result")) and "dt" not in inputs.steps[inputs.last_step]
        horizon = None if (complete and ended_at is None) else inputs.last_step
        comparison = compare_logs(log, replay, horizon_step=horizon, tolerance=tolerance, other_code=setup.other_code)
        summary = None
        if whatif:
            summary = summarize(log, replay, comparison)
        compare_wall = time.perf_counter() - c0
    logged = log.result
    clock = inputs.reads.get("clock.now")
    t_start = float(clock[0].rec["t"]) if clock else float(inputs.steps[0]["t"])
    mission_s = float(inputs.steps[min(backend.step, inputs.last_step)]["t"]) - t_start
    return ReplayReport(
        log_path=Path(path),
        whatif=whatif,
        changes=setup.changes,
        notes=setup.notes,
        comparison=comparison,
        logged_outcome=logged.get("outcome") if logged else None,
        replay_outcome=result.outcome if result is not None else None,
        replay_cause=result.failure_cause if result is not None else None,
        ended_at_step=ended_at,
        log_truncated=not complete,
        steps=backend.step + 1,
        mission_s=mission_s,
        wall_s=loop_wall,
        cpu_s=loop_cpu,
        setup_wall_s=wall - loop_wall,
        compare_wall_s=compare_wall,
        replay_log=Path(out) if out is not None else None,
        summary=summary,
        logs=LogPair(log, replay),
    )
