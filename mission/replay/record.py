"""Record every input of the supervisor at the device boundary.

:class:`RecordingBackend` wraps any :class:`hal.interfaces.Backend` (the
simulator, real devices, or a :class:`mission.replay.serve.ReplayBackend`) and
hands the supervisor proxies (:mod:`mission.replay.proxies`) that behave exactly
like the wrapped clock and devices, and note what each call returned (readings,
health, ``None``, the exception it raised) and every command sent.
:class:`RecordingQueue` does the same for the operator commands the supervisor
drains. Each ``advance(dt)`` ends a step; ``/replay/steps`` messages hold the
records of :data:`~mission.replay.schema.STEPS_PER_MESSAGE` steps; the step still
open when the backend closes ends there (:mod:`mission.replay.steplog`).

Records are keyed by (step, call name, k): ``step`` counts the ``advance``
calls so far, ``k`` the calls of that name within the step. A read is written
only when its result differs from the previous read of the same name (not the
same object - readings are never changed in place - and not the same values),
so a slowly changing health or an unchanged detection costs nothing; a replay
serves, for call (step, k), the last record at or before it. Operator drains are
written when they return commands; commands always. Simulator ground truth is
not an input of the supervisor (it feeds only ``/ground_truth`` and ``sim``
events) and is not recorded.
"""

from __future__ import annotations

import functools
import hashlib
import importlib
from collections.abc import Callable
from pathlib import Path
from types import TracebackType
from typing import Any

from hal.interfaces import Backend, DeviceSet
from mission.replay.proxies import extra_methods, recording_proxy
from mission.replay.schema import FORMAT
from mission.replay.steplog import Recorder, RecordingClock, StepLog
from mission.runtime.inputrecord import register_input_recorder
from mission.runtime.operator import Commands, OperatorCommand
from mission.runtime.pylog import Emit, LogCapture, LogLine

__all__ = [
    "RecordingBackend",
    "RecordingClock",
    "RecordingLogCapture",
    "RecordingQueue",
    "code_fingerprint",
    "device_header",
    "extra_methods",
]


CODE_PACKAGES = ("mission", "behaviours", "kcl", "hal", "maris_common")


@functools.lru_cache(maxsize=1)
def code_fingerprint() -> str:
    """Short SHA-1 of the Python source of :data:`CODE_PACKAGES` (computed once per
    process): a replay by other code says so."""

    h = hashlib.sha1()
    for name in CODE_PACKAGES:
        try:
            file = importlib.import_module(name).__file__
        except ImportError:
            continue
        if file is None:
            continue
        root = Path(file).parent
        for f in sorted(root.rglob("*.py")):
            h.update(str(f.relative_to(root.parent)).encode())
            h.update(f.read_bytes())
    return h.hexdigest()[:12]


def device_header(devices: DeviceSet) -> dict:
    """What a replay backend needs to stand in for ``devices`` (roles, names, static
    properties, the driver's own methods)."""
    roles = devices.by_role()
    return {
        "devices": [
            {"role": r, "name": str(getattr(d, "name", r)), "kind": type(d).__name__, "extras": extra_methods(d)}
            for r, d in roles.items()
        ],
        "joint_names": [str(n) for n in devices.arm.joint_names],
        "actuated_dofs": [bool(b) for b in devices.vehicle.actuated_dofs],
        "preshapes": [str(p) for p in devices.gripper.preshapes] if devices.gripper is not None else [],
        "operator_roles": list(devices.operators),  # in their order: the calls on them are in it
    }


# ------------------------------------------------------------------- backend
class RecordingBackend(Backend):
    """``inner`` with every input recorded into ``log`` (a :class:`mission.logs.writer.RunLogWriter`).

    Other attributes (the simulator's ``inject``, ``params``...) are the inner
    backend's: they are for the code that set the run up, not the supervisor."""

    def __init__(self, inner: Backend, log: Any = None, *, mission_file: str | Path | None = None) -> None:
        """``log`` may be attached later (:meth:`attach`), before the first step ends."""
        self.inner = inner
        self.steps = StepLog(log)
        self.recorder = Recorder(self.steps)
        self.realtime = bool(getattr(inner, "realtime", False))
        devs = inner.devices
        wrapped = {role: recording_proxy(role, dev, self.recorder) for role, dev in devs.by_role().items()}
        self.devices = DeviceSet.from_roles(wrapped)
        header = {
            "format": FORMAT,
            "backend": type(inner).__name__,
            "realtime": self.realtime,
            "code": code_fingerprint(),
        }
        if mission_file is not None:
            header["mission_file"] = str(Path(mission_file).resolve())
        header.update(device_header(devs))
        self.steps.header = header
        self.clock = RecordingClock(inner.clock, self.recorder)
        self._open = self.recorder.stream("backend.open")
        self._closed = False

    @property
    def backend(self) -> Backend:
        """The backend the supervisor runs on (:class:`mission.runtime.inputrecord.InputRecord`): this one."""
        return self

    def attach(self, log: Any) -> None:
        """Write the record into ``log`` (the header, if the clock was read already, now)."""
        self.steps.log = log
        self.steps.write_header()

    def record_commands(self, commands: Commands) -> RecordingQueue:
        """The operator queue ``commands`` with its drains recorded."""
        return RecordingQueue(commands, self)

    def log_capture(self, emit: Emit) -> RecordingLogCapture:
        """The supervisor's ``log_capture`` for this backend (records from a replayed
        log when the inner backend serves them, else from Python logging)."""
        return RecordingLogCapture(emit, self, getattr(self.inner, "pylog_records", None))

    def __getattr__(self, name: str) -> Any:
        if name == "inner":  # not set yet (during __init__): no recursion
            raise AttributeError(name)
        return getattr(self.inner, name)

    def open(self) -> None:
        k = self._open.next_k(self.steps)
        try:
            self.inner.open()
        except Exception as exc:
            self._open.error(self.steps, k, exc)
            raise

    def advance(self, dt: float) -> None:
        self.steps.end_step(dt)
        self.inner.advance(dt)

    def prefetch_health(self) -> None:
        """Passed on, not recorded: it returns nothing; the health it prepares is recorded
        when the supervisor reads it (a replay serves that)."""
        self.inner.prefetch_health()

    def close(self) -> None:
        """Write the step still open (the last one), then close the inner backend."""
        if not self._closed:
            self._closed = True
            self.steps.end_step(None)
            self.steps.write()
        self.inner.close()

    def ground_truth(self) -> dict | None:
        return self.inner.ground_truth()

    def truth_brief(self) -> dict | None:
        return self.inner.truth_brief()


class RecordingLogCapture:
    """The supervisor's capture of Python logging records (drivers' warnings turned into
    ``python_log`` events, :class:`mission.runtime.pylog.LogCapture`), with every
    non-empty drain recorded (``pylog.drain``).

    ``source``: where the records come from instead of the logging system (a
    replay: the records the logged run drained at this drain)."""

    def __init__(
        self,
        emit: Emit,
        backend: RecordingBackend,
        source: Callable[[], list[LogLine]] | None = None,
    ) -> None:
        self._capture = LogCapture(emit)
        self._steps = backend.steps
        self._stream = backend.recorder.stream("pylog.drain")
        self._source = source

    def __enter__(self) -> RecordingLogCapture:
        if self._source is None:
            self._capture.install()
        return self

    def __exit__(self, kind: type[BaseException] | None, exc: BaseException | None, tb: TracebackType | None) -> None:
        self.drain()  # a last time
        if self._source is None:
            self._capture.remove()

    def drain(self) -> int:
        k = self._stream.next_k(self._steps)
        items = list(self._source()) if self._source is not None else self._capture.take()
        if items:
            recs = [{"logger": n, "level": lv, "text": tx} for n, lv, tx in items]
            self._stream.put(self._steps, k, {"records": recs})
        for item in items:
            self._capture.emit_record(*item)
        return len(items)


class RecordingQueue:
    """An operator :class:`mission.runtime.operator.CommandQueue` whose drains are recorded."""

    def __init__(self, inner: Commands, backend: RecordingBackend) -> None:
        self.inner = inner
        self._rec = backend.recorder
        self._stream = backend.recorder.stream("operator.drain")

    def put(self, command: str, source: str) -> None:
        self.inner.put(command, source)

    def drain(self) -> list[OperatorCommand]:
        steps = self._rec.steps
        k = self._stream.next_k(steps)
        items = self.inner.drain()
        if items:
            self._stream.put(steps, k, {"commands": [{"command": c, "source": s} for c, s in items]})
        return items


def record_inputs(backend: Backend, mission_file: str | Path | None) -> RecordingBackend:
    """The input record of a run of ``mission_file`` on ``backend``: the recorder this
    module registers with :mod:`mission.runtime.inputrecord` when imported."""
    return RecordingBackend(backend, mission_file=mission_file)


register_input_recorder(record_inputs)
