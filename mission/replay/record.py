"""Record every input of the supervisor at the device boundary.

:class:`RecordingBackend` wraps any :class:`hal.interfaces.Backend` (the
simulator, real devices, or a :class:`mission.replay.serve.ReplayBackend`) and
hands the supervisor proxies that behave exactly like the wrapped clock and
devices, and note what each call returned (readings, health, ``None``, the
exception it raised) and every command sent. :class:`RecordingQueue` does the
same for the operator commands the supervisor drains. Each ``advance(dt)``
ends a step; ``/replay/steps`` messages hold the records of
:data:`~mission.replay.schema.STEPS_PER_MESSAGE` steps; the step still open
when the backend closes ends there.

Records are keyed by (step, call name, k): ``step`` counts the ``advance``
calls so far, ``k`` the calls of that name within the step. A read is written
only when its result differs from the previous read of the same name (the
same object - readings are never changed in place - or the same JSON bytes), so a slowly changing health or an unchanged detection costs
nothing; a replay serves, for call (step, k), the last record at or before it.
Operator drains are written when they return commands; commands always.
Simulator ground truth is not an input of the supervisor (it feeds only
``/ground_truth`` and ``sim`` events) and is not recorded.
"""

from __future__ import annotations

import functools
import math
from pathlib import Path
from typing import Any, Callable

import numpy as np
import orjson

from hal.interfaces import (
    Arm,
    Backend,
    Detection,
    DeviceSet,
    ForceTorqueSensor,
    Gripper,
    GripperState,
    Health,
    JointState,
    NavigationState,
    TargetDetector,
    Vehicle,
    Wrench,
)
from mission.replay import codec
from mission.runtime.pylog import LogCapture
from mission.replay.schema import FORMAT, HEADER_TOPIC, STEP_TOPIC, STEPS_PER_MESSAGE


class StepLog:
    """The records of the step in progress, written to the run log in batches of steps."""

    def __init__(self, log: Any) -> None:
        self.log = log
        self.step = 0
        #: Last clock reading served (s): the time of the step.
        self.t = 0.0
        #: Read records of this step, encoded (JSON object bytes).
        self.reads: list[orjson.Fragment] = []
        #: Commands of this step, as ``{"call", "values"/"text", ...}`` (encoded with the step).
        self.commands: list[dict] = []
        #: The ``/replay/header`` message, written with the first steps (its time is the
        #: first clock reading: reading the clock for it would be one more call to serve).
        self.header: dict | None = None
        self.t_first: float | None = None
        self.batch: list[dict] = []

    def write_header(self) -> None:
        if self.header is not None and self.log is not None:
            header, self.header = self.header, None
            self.log.write(HEADER_TOPIC, self.t if self.t_first is None else self.t_first, header)

    def end_step(self, dt: float | None) -> None:
        """Close the step (``dt``: the advance that ends it, None for the last one)."""
        rec: dict[str, Any] = {"step": self.step, "t": self.t}
        if dt is not None:
            rec["dt"] = dt
        rec["reads"] = self.reads
        cmds = self.commands
        if cmds:
            data = orjson.dumps(cmds, default=codec.default, option=codec.OPTIONS)
            if b"null" in data:  # a non-finite value: named in the command's nonfinite list
                data = orjson.dumps([codec.mark_nonfinite(c) for c in cmds], default=codec.default, option=codec.OPTIONS)
            rec["commands"] = orjson.Fragment(data)
        else:
            rec["commands"] = cmds
        self.batch.append(rec)
        self.reads = []
        self.commands = []
        self.step += 1
        if len(self.batch) >= STEPS_PER_MESSAGE:
            self.write()

    def write(self) -> None:
        """Write the steps closed so far."""
        self.write_header()
        if self.batch:
            self.log.write(STEP_TOPIC, self.t, {"steps": self.batch})
            self.batch = []


class _Stream:
    """One call name: its per-step call counter and last written result."""

    __slots__ = ("name", "prefix", "step", "k", "last", "last_obj")

    def __init__(self, name: str) -> None:
        self.name = name
        self.prefix = b'{"call":' + orjson.dumps(name) + b',"k":'
        self.step = -1
        self.k = 0
        self.last: bytes | None = None
        self.last_obj: Any = None

    def next_k(self, steps: StepLog) -> int:
        if self.step != steps.step:
            self.step = steps.step
            self.k = 0
        else:
            self.k += 1
        return self.k

    def put(self, steps: StepLog, k: int, body: bytes, *, always: bool = False) -> None:
        """Append the record ``body`` (JSON object bytes) unless it repeats the last one."""
        if always or body != self.last:
            self.last = body
            steps.reads.append(orjson.Fragment(self.prefix + str(k).encode() + b"," + body[1:]))

    def error(self, steps: StepLog, k: int, exc: BaseException) -> None:
        self.last = self.last_obj = None  # the next result is written whatever it is
        steps.reads.append(orjson.Fragment(self.prefix + str(k).encode() + b"," + codec.dumps(codec.error_fields(exc))[1:]))


class _Recorder:
    """Shared by the proxies: reads and commands into one :class:`StepLog`.

    Every recorded call goes through here, many times per step: keep it lean."""

    def __init__(self, steps: StepLog) -> None:
        self.steps = steps
        self._streams: dict[str, _Stream] = {}

    def stream(self, name: str) -> _Stream:
        s = self._streams.get(name)
        if s is None:
            s = self._streams[name] = _Stream(name)
        return s

    def read(self, stream: _Stream, fn: Callable[[], Any], encode: Callable[[Any], dict]) -> Any:
        """``fn()``, its result (or exception) recorded as call ``stream.name``."""
        steps = self.steps
        if stream.step != steps.step:
            stream.step = steps.step
            stream.k = k = 0
        else:
            stream.k = k = stream.k + 1
        try:
            value = fn()
        except Exception as exc:
            stream.error(steps, k, exc)
            raise
        if value is not stream.last_obj or value is None:  # a cached reading handed out again costs nothing
            stream.last_obj = value
            body = orjson.dumps(encode(value), default=codec.default, option=codec.OPTIONS)
            if b"null" in body:
                body = codec.dumps(encode(value))
            if body != stream.last:
                stream.last = body
                steps.reads.append(orjson.Fragment(stream.prefix + str(k).encode() + b"," + body[1:]))
        return value

    def call(self, stream: _Stream, fn: Callable[..., Any], args: tuple, kwargs: dict) -> Any:
        """A driver's own method (beyond :mod:`hal.interfaces`, e.g. ``reset_faults``): its
        arguments and result (JSON text) recorded, every time."""
        steps = self.steps
        k = stream.next_k(steps)
        try:
            value = fn(*args, **kwargs)
        except Exception as exc:
            stream.error(steps, k, exc)
            raise
        rec: dict[str, Any] = {"result": codec.dumps_value(value)}
        if args or kwargs:
            rec["args"] = codec.dumps_value({"args": list(args), "kwargs": kwargs})
        stream.put(steps, k, codec.dumps(rec), always=True)
        return value

    def command(self, call: str, fn: Callable[..., Any], *args: Any, values: Any = None, text: str | None = None) -> Any:
        """``fn(*args)``, recorded as command ``call`` with its ``values`` (numbers) or ``text``."""
        rec: dict[str, Any] = {"call": call}
        if values is not None:
            rec["values"] = values.tolist() if type(values) is np.ndarray and values.dtype is codec.F64 else codec.f64(values).tolist()
        elif text is not None:
            rec["text"] = text
        self.steps.commands.append(rec)  # before the call: a command that raises keeps its place in the order
        try:
            return fn(*args)
        except Exception as exc:
            rec.update(codec.error_fields(exc))
            raise


class RecordingClock:
    """The wrapped clock; each reading that differs from the previous one is recorded."""

    def __init__(self, inner: Any, rec: _Recorder) -> None:
        self._now = inner.now
        self._steps = rec.steps
        self._stream = rec.stream("clock.now")
        self._last: float | None = None

    def now(self) -> float:
        t = self._now()
        steps = self._steps
        stream = self._stream
        if stream.step != steps.step:
            stream.step = steps.step
            stream.k = k = 0
        else:
            stream.k = k = stream.k + 1
        last = self._last
        if t != last or (t == 0.0 and math.copysign(1.0, t) != math.copysign(1.0, last)):  # type: ignore[arg-type]
            if last is None:
                steps.t_first = t
            self._last = t
            steps.reads.append(orjson.Fragment(stream.prefix + str(k).encode() + b',"t":'
                                               + orjson.dumps(t, option=codec.OPTIONS) + b"}"))
        steps.t = t
        return t


# ------------------------------------------------------------------- devices
class _DeviceProxy:
    """Common part: health and safe stop recorded, life cycle forwarded."""

    def _setup(self, inner: Any, role: str, rec: _Recorder) -> None:
        self._inner = inner
        self._role = role
        self._rec = rec
        self.name = getattr(inner, "name", role)
        self._health = rec.stream(f"{role}.health")
        self._safe_stop_call = f"{role}.safe_stop"
        self._extras = frozenset(extra_methods(inner))

    def __getattr__(self, name: str) -> Any:
        """The driver's own methods, recorded (``reset_faults``...); its other attributes
        as they are, unrecorded (supervisor code must not depend on them: a replay has none)."""
        if name.startswith("_"):
            raise AttributeError(name)
        attr = getattr(self._inner, name)
        if name not in self._extras:
            return attr
        stream = self._rec.stream(f"{self._role}.{name}")
        rec = self._rec
        return lambda *args, **kwargs: rec.call(stream, attr, args, kwargs)

    def connect(self) -> None:
        self._inner.connect()

    def disconnect(self) -> None:
        self._inner.disconnect()

    def health(self) -> Health:
        return self._rec.read(self._health, self._inner.health, codec.enc_health)

    def safe_stop(self) -> None:
        self._rec.command(self._safe_stop_call, self._inner.safe_stop)


class RecordingVehicle(_DeviceProxy, Vehicle):
    def __init__(self, inner: Vehicle, rec: _Recorder) -> None:
        self._setup(inner, "vehicle", rec)
        self.actuated_dofs = tuple(inner.actuated_dofs)
        self._nav = rec.stream("vehicle.navigation")
        self._armed = rec.stream("vehicle.armed")

    def arm(self) -> None:
        self._rec.command("vehicle.arm", self._inner.arm)

    def disarm(self) -> None:
        self._rec.command("vehicle.disarm", self._inner.disarm)

    @property
    def armed(self) -> bool:
        return self._rec.read(self._armed, lambda: self._inner.armed, codec.enc_bool)

    def command_body_velocity(self, v: np.ndarray) -> None:
        self._rec.command("vehicle.command_body_velocity", self._inner.command_body_velocity, v, values=v)

    def navigation(self) -> NavigationState:
        return self._rec.read(self._nav, self._inner.navigation, codec.enc_navigation)


class RecordingArm(_DeviceProxy, Arm):
    def __init__(self, inner: Arm, rec: _Recorder) -> None:
        self._setup(inner, "arm", rec)
        self.joint_names = tuple(inner.joint_names)
        self._js = rec.stream("arm.joint_state")

    def enable(self) -> None:
        self._rec.command("arm.enable", self._inner.enable)

    def disable(self) -> None:
        self._rec.command("arm.disable", self._inner.disable)

    def command_joint_velocity(self, qdot: np.ndarray) -> None:
        self._rec.command("arm.command_joint_velocity", self._inner.command_joint_velocity, qdot, values=qdot)

    def joint_state(self) -> JointState:
        return self._rec.read(self._js, self._inner.joint_state, codec.enc_joints)


class RecordingGripper(_DeviceProxy, Gripper):
    def __init__(self, inner: Gripper, rec: _Recorder) -> None:
        self._setup(inner, "gripper", rec)
        self.preshapes = tuple(inner.preshapes)
        self._state = rec.stream("gripper.state")

    def preshape(self, shape: str) -> None:
        self._rec.command("gripper.preshape", self._inner.preshape, shape, text=str(shape))

    def close(self, current_limit: float) -> None:
        self._rec.command("gripper.close", self._inner.close, current_limit, values=[current_limit])

    def open(self) -> None:
        self._rec.command("gripper.open", self._inner.open)

    def stop(self) -> None:
        self._rec.command("gripper.stop", self._inner.stop)

    def state(self) -> GripperState:
        return self._rec.read(self._state, self._inner.state, codec.enc_gripper)


class RecordingWrenchSensor(_DeviceProxy, ForceTorqueSensor):
    def __init__(self, inner: ForceTorqueSensor, rec: _Recorder) -> None:
        self._setup(inner, "wrench_sensor", rec)
        self._w = rec.stream("wrench_sensor.wrench")

    def wrench(self) -> Wrench | None:
        return self._rec.read(self._w, self._inner.wrench, codec.enc_wrench)


class RecordingDetector(_DeviceProxy, TargetDetector):
    def __init__(self, inner: TargetDetector, rec: _Recorder) -> None:
        self._setup(inner, "detector", rec)
        self._latest = rec.stream("detector.latest")

    def latest(self) -> Detection | None:
        return self._rec.read(self._latest, self._inner.latest, codec.enc_detection)

    def camera_frames(self) -> list:
        """The detector's images, for the log's vision channels only (no decision reads
        them): passed on, not recorded (a replay has none)."""
        return self._inner.camera_frames()


_PROXIES = {"vehicle": RecordingVehicle, "arm": RecordingArm, "gripper": RecordingGripper,
            "wrench_sensor": RecordingWrenchSensor, "detector": RecordingDetector}


_INTERFACES = {"vehicle": Vehicle, "arm": Arm, "gripper": Gripper, "wrench_sensor": ForceTorqueSensor,
               "detector": TargetDetector}


def extra_methods(device: Any) -> list[str]:
    """Public methods of ``device``'s class beyond its :mod:`hal.interfaces` role."""
    base = next((cls for cls in _INTERFACES.values() if isinstance(device, cls)), object)
    known = set(dir(base))
    return sorted(n for n in dir(type(device)) if not n.startswith("_") and n not in known
                  and callable(getattr(type(device), n, None)))


#: Packages whose source decides what the supervisor does with its inputs.
CODE_PACKAGES = ("mission", "behaviours", "kcl", "hal", "maris_common")


@functools.lru_cache(maxsize=1)
def code_fingerprint() -> str:
    """Short SHA-1 of the Python source of :data:`CODE_PACKAGES` (computed once per
    process, a few ms): a replay by other code says so."""
    import hashlib
    import importlib

    h = hashlib.sha1()
    for name in CODE_PACKAGES:
        try:
            root = Path(importlib.import_module(name).__file__).parent
        except (ImportError, TypeError):
            continue
        for f in sorted(root.rglob("*.py")):
            h.update(str(f.relative_to(root.parent)).encode())
            h.update(f.read_bytes())
    return h.hexdigest()[:12]


def kcl_path() -> str:
    """Which TPIK implementation this process runs: ``compiled`` (Numba) or ``numpy``
    (``MARIS_ICAT_NO_JIT=1`` or no Numba); they agree to rounding, not bit for bit."""
    try:
        from kcl import icat

        return "numpy" if icat._kernel() is None else "compiled"  # noqa: SLF001 - the dispatch's own choice
    except Exception:  # noqa: BLE001 - informative only
        return "unknown"


def device_header(devices: DeviceSet) -> dict:
    """What a replay backend needs to stand in for ``devices`` (roles, names, static
    properties, the driver's own methods)."""
    roles = devices.by_role()
    return {
        "devices": [{"role": r, "name": str(getattr(d, "name", r)), "kind": type(d).__name__, "extras": extra_methods(d)}
                    for r, d in roles.items()],
        "joint_names": [str(n) for n in devices.arm.joint_names],
        "actuated_dofs": [bool(b) for b in devices.vehicle.actuated_dofs],
        "preshapes": [str(p) for p in devices.gripper.preshapes] if devices.gripper is not None else [],
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
        self.recorder = _Recorder(self.steps)
        self.realtime = bool(getattr(inner, "realtime", False))
        devs = inner.devices
        wrapped = {role: _PROXIES[role](dev, self.recorder) for role, dev in devs.by_role().items()}
        self.devices = DeviceSet(**wrapped)
        header = {"format": FORMAT, "backend": type(inner).__name__, "realtime": self.realtime, "kcl_path": kcl_path(),
                  "code": code_fingerprint()}
        if mission_file is not None:
            header["mission_file"] = str(Path(mission_file).resolve())
        header.update(device_header(devs))
        self.steps.header = header
        self.clock = RecordingClock(inner.clock, self.recorder)
        self._open = self.recorder.stream("backend.open")
        self._closed = False

    def attach(self, log: Any) -> None:
        """Write the record into ``log`` (the header, if the clock was read already, now)."""
        self.steps.log = log
        self.steps.write_header()

    def log_capture(self, emit: Callable[..., Any]) -> RecordingLogCapture:
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

    def close(self) -> None:
        """Write the step still open (the last one), then close the inner backend."""
        if not self._closed:
            self._closed = True
            self.steps.end_step(None)
            self.steps.write()
        self.inner.close()

    def ground_truth(self) -> dict | None:
        return self.inner.ground_truth()


class RecordingLogCapture(LogCapture):
    """The supervisor's capture of Python logging records (drivers' warnings turned into
    ``python_log`` events), with every non-empty drain recorded (``pylog.drain``).

    ``source``: where the records come from instead of the logging system (a
    replay: the records the logged run drained at this drain)."""

    def __init__(self, emit: Callable[..., Any], backend: "RecordingBackend",
                 source: Callable[[], list[tuple[str, str, str]]] | None = None) -> None:
        super().__init__(emit)
        self._steps = backend.steps
        self._stream = backend.recorder.stream("pylog.drain")
        self._source = source

    def __enter__(self) -> "RecordingLogCapture":
        if self._source is None:
            super().__enter__()
        return self

    def __exit__(self, *exc: object) -> None:
        if self._source is None:
            super().__exit__(*exc)  # drains a last time
        else:
            self.drain()

    def drain(self) -> int:
        k = self._stream.next_k(self._steps)
        if self._source is not None:
            items = list(self._source())
        else:
            items = []
            while self._queue:
                items.append(self._queue.popleft())
        if items:
            recs = [{"logger": n, "level": lv, "text": tx} for n, lv, tx in items]
            self._stream.put(self._steps, k, codec.dumps({"records": recs}), always=True)
        for item in items:
            self.emit_record(*item)
        return len(items)


class RecordingQueue:
    """An operator :class:`mission.runtime.operator.CommandQueue` whose drains are recorded."""

    def __init__(self, inner: Any, backend: RecordingBackend) -> None:
        self.inner = inner
        self._rec = backend.recorder
        self._stream = backend.recorder.stream("operator.drain")

    def put(self, command: str, source: str) -> None:
        self.inner.put(command, source)

    def drain(self) -> list[tuple[str, str]]:
        steps = self._rec.steps
        k = self._stream.next_k(steps)
        items = self.inner.drain()
        if items:
            body = codec.dumps({"commands": [{"command": c, "source": s} for c, s in items]})
            self._stream.put(steps, k, body, always=True)
        return items
