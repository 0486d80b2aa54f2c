"""The input record of a run, as the runtime sees it: an interface and the hook
that fills it.

With a log, :func:`mission.runtime.api.run_mission` wraps the backend so that
every input the supervisor consumes (readings, health, clock, operator
commands, Python logging records) goes into the log, for ``maris log replay``.
The recorder is :mod:`mission.replay.record`: the replay package is built on
the runtime (a replay runs the supervisor again), so it registers its recorder
here when imported instead of the runtime importing it. The entry points that
write logs (the CLI's runner, campaigns, the replay itself) import it.
"""

from __future__ import annotations

from pathlib import Path
from typing import Protocol

from hal.interfaces import Backend
from mission.runtime.operator import Commands
from mission.runtime.pylog import Emit, RunLogCapture


class InputRecord(Protocol):
    """A backend wrapped so that every input the supervisor consumes is recorded."""

    @property
    def backend(self) -> Backend:
        """The backend the supervisor runs on: the wrapped one, through the record."""
        ...

    def attach(self, log: object) -> None:
        """Write the record into ``log`` (a :class:`mission.logs.writer.RunLogWriter`)."""
        ...

    def record_commands(self, commands: Commands) -> Commands:
        """``commands`` with every drain recorded."""
        ...

    def log_capture(self, emit: Emit) -> RunLogCapture:
        """The supervisor's capture of Python logging records, recorded
        (a :class:`mission.runtime.pylog.LogCaptureFactory`)."""
        ...


class InputRecorder(Protocol):
    """Wraps ``backend`` for a run of ``mission_file``."""

    def __call__(self, backend: Backend, mission_file: str | Path | None) -> InputRecord: ...


_recorder: InputRecorder | None = None


def register_input_recorder(recorder: InputRecorder) -> None:
    """Make ``recorder`` the input record of every run with a log from now on."""
    global _recorder
    _recorder = recorder


def input_recorder() -> InputRecorder | None:
    """The registered input recorder (None: :mod:`mission.replay.record` not imported)."""
    return _recorder
