"""A backend that serves a run log's recorded inputs back: :class:`ReplayBackend`.

It implements :class:`hal.interfaces.Backend` with the devices named in the
log's ``/replay/header``; the supervisor cannot tell it from the devices that
ran. Call (step, k) of a read gets the last record of that call name at or
before (step, k) (records are written only when a result changed, see
:mod:`mission.replay.record`); an exception recorded at exactly (step, k) is
raised again (same type name, same message). Commands go nowhere, except that
a command which raised in the run raises again at the same (step, k).
Operator commands are handed out at the first drain at or after the one that
consumed them. ``advance(dt)`` moves to the next recorded step; past the last
one it raises :class:`EndOfLog`, which is not an ``Exception`` so that it
passes through the supervisor's fault handling and ends the replay.

In an exact replay every call matches a record. In an open-loop what-if a
changed mission or controller may read at other times: it gets the reading as
it stood then (the latest before), never one from the future; a reading the log
never had raises :class:`ReplayGap`.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from typing import Any, NamedTuple

import numpy as np
import orjson

from hal.interfaces import (
    Arm,
    Backend,
    Detection,
    Device,
    DeviceSet,
    DofFlags,
    ForceTorqueSensor,
    Gripper,
    GripperState,
    Health,
    JointState,
    NavigationState,
    OperatorInput,
    OperatorSample,
    SearchSeed,
    TargetDetector,
    Vehicle,
    Wrench,
    dof_flags,
)
from mission.replay import codec
from mission.replay.schema import FORMAT, HEADER_TOPIC, STEP_TOPIC, record_steps
from mission.runtime.operator import OperatorCommand


class EndOfLog(BaseException):
    """The replay reached the last recorded step (``step``: the first step the log does not have)."""

    def __init__(self, step: int) -> None:
        super().__init__(f"the log ends before step {step}")
        self.step = step


class ReplayStop(BaseException):
    """The replay cannot go on faithfully (e.g. the mission's base rate differs from the log's)."""


class ReplayGap(Exception):
    """A read the log has no record for (an open-loop what-if reading something the run never read)."""


class NotReplayable(Exception):
    """The log has no input record (written before input logging existed, or not a run log)."""


@dataclass
class _Entry:
    step: int
    k: int
    rec: dict
    value: Any = None
    decoded: bool = False


@dataclass
class _Cursor:
    """Walks the records of one call name forward in (step, k) order."""

    entries: list[_Entry] = field(default_factory=list)
    i: int = -1
    #: Index of the last entry at or before the cursor that is a value (not an error).
    good: int = -1

    def seek(self, step: int, k: int) -> _Entry | None:
        """The last entry at or before (step, k), or None."""
        entries = self.entries
        i = self.i
        n = len(entries)
        while i + 1 < n and (entries[i + 1].step, entries[i + 1].k) <= (step, k):
            i += 1
            if "error_type" not in entries[i].rec:
                self.good = i
        self.i = i
        return entries[i] if i >= 0 else None


class RecordedError(NamedTuple):
    """An exception a call raised in the logged run: its type's name, message and module."""

    type_name: str
    message: str
    module: str | None


@dataclass
class ReplayInputs:
    """The decoded input record of one log."""

    header: dict
    #: step -> its record (``t``, ``dt``, ``reads``, ``commands``).
    steps: dict[int, dict]
    last_step: int
    #: call name -> records in (step, k) order.
    reads: dict[str, list[_Entry]]
    #: (call, step, k) -> the exception of each command that raised.
    command_errors: dict[tuple[str, int, int], RecordedError]

    @classmethod
    def from_log(cls, log: Any) -> ReplayInputs:
        """From a log's ``messages`` (a :class:`mission.replay.rawlog.RawLog`, as ``maris log
        replay`` opens it, or any log with that method); its ``metadata``, where it has one,
        says why a log has no record. :class:`NotReplayable` without a record."""
        headers = log.messages(HEADER_TOPIC)
        msgs = record_steps(log)
        if not headers or not msgs:
            missing = f"{log.path} has no input record ({HEADER_TOPIC}, {STEP_TOPIC})"
            if getattr(log, "metadata", {}).get("maris.run", {}).get("input_record") == "no":
                raise NotReplayable(
                    f"{missing}: the run left it out (`maris sim --no-input-record`); run the "
                    "mission again without that option for a log that can be replayed"
                )
            raise NotReplayable(
                f"{missing}: it was written without input logging (before it existed), so it cannot be replayed"
            )
        header = headers[0]
        if header.get("format") != FORMAT:
            raise NotReplayable(
                f"{log.path}: input record format {header.get('format')!r}; this program reads {FORMAT}"
            )
        steps: dict[int, dict] = {}
        for m in msgs:
            steps[int(m["step"])] = m
        last = max(steps)
        gaps = [s for s in range(last + 1) if s not in steps]
        if gaps:
            raise NotReplayable(f"{log.path}: the input record lacks step {gaps[0]} (of 0..{last})")
        reads: dict[str, list[_Entry]] = {}
        errors: dict[tuple[str, int, int], RecordedError] = {}
        for s in range(last + 1):
            for r in steps[s].get("reads", ()):
                reads.setdefault(r["call"], []).append(_Entry(s, int(r["k"]), r))
            counts: dict[str, int] = {}
            for c in steps[s].get("commands", ()):
                k = counts.get(c["call"], 0)
                counts[c["call"]] = k + 1
                if "error_type" in c:
                    errors[(c["call"], s, k)] = RecordedError(
                        c["error_type"], c.get("error", ""), c.get("error_module")
                    )
        return cls(header, steps, last, reads, errors)


class _Server:
    """Per-call counters and cursors over :class:`ReplayInputs` for the current step."""

    def __init__(self, inputs: ReplayInputs) -> None:
        self.inputs = inputs
        self.step = 0
        self._cursors = {name: _Cursor(entries) for name, entries in inputs.reads.items()}
        self._k: dict[str, int] = {}
        self._k_step = 0

    def next_k(self, call: str) -> int:
        if self._k_step != self.step:
            self._k_step = self.step
            self._k = {}
        k = self._k.get(call, 0)
        self._k[call] = k + 1
        return k

    def read(self, call: str, decode: Any) -> Any:
        k = self.next_k(call)
        cur = self._cursors.get(call)
        entry = cur.seek(self.step, k) if cur is not None else None
        if entry is not None and cur is not None and "error_type" in entry.rec:
            if (entry.step, entry.k) == (self.step, k):
                raise codec.rebuild_error(
                    entry.rec["error_type"], entry.rec.get("error", ""), entry.rec.get("error_module")
                )
            entry = cur.entries[cur.good] if cur.good >= 0 else None
        if entry is None:
            raise ReplayGap(
                f"the log has no `{call}` result at or before step {self.step}: an open-loop replay "
                "can only serve what the run read"
            )
        if not entry.decoded:
            entry.value = decode(entry.rec)
            entry.decoded = True
        return entry.value

    def command(self, call: str) -> None:
        k = self.next_k(call)
        err = self.inputs.command_errors.get((call, self.step, k))
        if err is not None:
            raise codec.rebuild_error(*err)

    def _pending(self, call: str) -> list[dict]:
        """Records of ``call`` at or before this call, not handed out yet (once each)."""
        k = self.next_k(call)
        cur = self._cursors.get(call)
        if cur is None:
            return []
        before = cur.i
        cur.seek(self.step, k)
        return [entry.rec for entry in cur.entries[before + 1 : cur.i + 1]]

    def drain(self) -> list[OperatorCommand]:
        """Operator commands consumed in the run at or before this drain, not handed out yet."""
        return [
            OperatorCommand(c["command"], c["source"])
            for rec in self._pending("operator.drain")
            for c in rec.get("commands", ())
        ]

    def pylog(self) -> list[tuple[str, str, str]]:
        """Python logging records the run turned into events at or before this drain, not handed out yet."""
        return [
            (r["logger"], r["level"], r["text"]) for rec in self._pending("pylog.drain") for r in rec.get("records", ())
        ]


class ReplayClock:
    def __init__(self, server: _Server) -> None:
        self._server = server

    def now(self) -> float:
        return self._server.read("clock.now", _dec_clock)


def _dec_clock(rec: dict) -> float:
    return float(rec["t"])


def _dec_result(rec: dict) -> Any:
    return orjson.loads(rec["result"]) if "result" in rec else None


class ServedDevice(Device):
    """What every replayed device does alike for its ``role``: health and safe stop
    served from the log, and the logged driver's own methods (``reset_faults``...)
    serving their logged results. The role devices below derive from it and from
    their role's interface."""

    def __init__(self, server: _Server, role: str, name: str) -> None:
        self._server = server
        self._role = role
        self.name = name
        self._health_call = f"{role}.health"
        self._safe_stop_call = f"{role}.safe_stop"
        devices = {d["role"]: d for d in server.inputs.header.get("devices", ())}
        self._extras = frozenset(devices.get(role, {}).get("extras", ()))

    def __getattr__(self, name: str) -> Any:
        """A logged driver method ``name``, serving its logged results; AttributeError otherwise."""
        if name.startswith("_") or name not in self._extras:
            raise AttributeError(name)
        call = f"{self._role}.{name}"
        server = self._server
        return lambda *args, **kwargs: server.read(call, _dec_result)

    def health(self) -> Health:
        return self._server.read(self._health_call, codec.dec_health)

    def safe_stop(self) -> None:
        self._server.command(self._safe_stop_call)


class ReplayVehicle(ServedDevice, Vehicle):
    def __init__(self, server: _Server, name: str, actuated_dofs: DofFlags) -> None:
        super().__init__(server, "vehicle", name)
        self.actuated_dofs = actuated_dofs

    def arm(self) -> None:
        self._server.command("vehicle.arm")

    def disarm(self) -> None:
        self._server.command("vehicle.disarm")

    @property
    def armed(self) -> bool:
        return self._server.read("vehicle.armed", codec.dec_bool)

    def command_body_velocity(self, v: np.ndarray) -> None:
        self._server.command("vehicle.command_body_velocity")

    def navigation(self) -> NavigationState:
        return self._server.read("vehicle.navigation", codec.dec_navigation)


class ReplayArm(ServedDevice, Arm):
    def __init__(self, server: _Server, name: str, joint_names: tuple[str, ...]) -> None:
        super().__init__(server, "arm", name)
        self.joint_names = joint_names

    def enable(self) -> None:
        self._server.command("arm.enable")

    def disable(self) -> None:
        self._server.command("arm.disable")

    def command_joint_velocity(self, qdot: np.ndarray) -> None:
        self._server.command("arm.command_joint_velocity")

    def joint_state(self) -> JointState:
        return self._server.read("arm.joint_state", codec.dec_joints)


class ReplayGripper(ServedDevice, Gripper):
    def __init__(self, server: _Server, name: str, preshapes: tuple[str, ...]) -> None:
        super().__init__(server, "gripper", name)
        self.preshapes = preshapes

    def preshape(self, shape: str) -> None:
        self._server.command("gripper.preshape")

    def close(self, current_limit: float) -> None:
        self._server.command("gripper.close")

    def open(self) -> None:
        self._server.command("gripper.open")

    def stop(self) -> None:
        self._server.command("gripper.stop")

    def state(self) -> GripperState:
        return self._server.read("gripper.state", codec.dec_gripper)


class ReplayWrenchSensor(ServedDevice, ForceTorqueSensor):
    def __init__(self, server: _Server, name: str) -> None:
        super().__init__(server, "wrench_sensor", name)

    def wrench(self) -> Wrench | None:
        return self._server.read("wrench_sensor.wrench", codec.dec_wrench)


class ReplayDetector(ServedDevice, TargetDetector):
    def __init__(self, server: _Server, name: str) -> None:
        super().__init__(server, "detector", name)

    def latest(self) -> Detection | None:
        return self._server.read("detector.latest", codec.dec_detection)

    def seed_search(self, seed: SearchSeed) -> bool:
        """The detector's logged answer to the operator's seed."""
        return bool(self._server.read("detector.seed_search", _dec_result))


class ReplayOperatorInput(ServedDevice, OperatorInput):
    """An operator input (``role``) serving the logged samples."""

    def __init__(self, server: _Server, role: str, name: str) -> None:
        super().__init__(server, role, name)
        self._latest_call = f"{role}.latest"

    def latest(self) -> OperatorSample | None:
        return self._server.read(self._latest_call, codec.dec_operator)


class ReplayBackend(Backend):
    """Serves ``inputs`` (:class:`ReplayInputs`) to the supervisor; no world behind it."""

    def __init__(self, inputs: ReplayInputs) -> None:
        self.inputs = inputs
        self.server = _Server(inputs)
        h = inputs.header
        self.realtime = bool(h.get("realtime", False))
        self.clock = ReplayClock(self.server)
        names = {d["role"]: d.get("name", d["role"]) for d in h.get("devices", ())}
        s = self.server
        devs: dict[str, Any] = {
            "vehicle": ReplayVehicle(
                s, names.get("vehicle", "vehicle"), dof_flags(h.get("actuated_dofs", (True,) * 6))
            ),
            "arm": ReplayArm(s, names.get("arm", "arm"), tuple(h.get("joint_names", ()))),
        }
        if "gripper" in names:
            devs["gripper"] = ReplayGripper(s, names["gripper"], tuple(h.get("preshapes", ())))
        if "wrench_sensor" in names:
            devs["wrench_sensor"] = ReplayWrenchSensor(s, names["wrench_sensor"])
        if "detector" in names:
            devs["detector"] = ReplayDetector(s, names["detector"])
        for role in h.get("operator_roles", ()):
            devs[role] = ReplayOperatorInput(s, role, names.get(role, role))
        self.devices = DeviceSet.from_roles(devs)
        #: perf_counter() and process_time() at open (the supervisor's start) and close (the run's end), s.
        self.wall_open: float | None = None
        self.wall_close: float | None = None
        self.cpu_open = self.cpu_close = 0.0

    @property
    def step(self) -> int:
        """Backend steps so far (``advance`` calls)."""
        return self.server.step

    def open(self) -> None:
        self.wall_open, self.cpu_open = time.perf_counter(), time.process_time()
        cur = self.server._cursors.get("backend.open")
        k = self.server.next_k("backend.open")
        if cur is not None:
            entry = cur.seek(self.server.step, k)
            if entry is not None and (entry.step, entry.k) == (self.server.step, k) and "error_type" in entry.rec:
                raise codec.rebuild_error(
                    entry.rec["error_type"], entry.rec.get("error", ""), entry.rec.get("error_module")
                )

    def close(self) -> None:
        """Nothing to release; notes the wall time (for the replay's speed)."""
        self.wall_close, self.cpu_close = time.perf_counter(), time.process_time()

    def advance(self, dt: float) -> None:
        s = self.server.step
        logged = self.inputs.steps[s].get("dt")
        if logged is not None and abs(float(logged) - dt) > 1e-12 * max(1.0, abs(dt)):
            raise ReplayStop(
                f"step {s} advances {dt:g} s but the log's step advanced {logged:g} s: the replayed "
                "mission must keep the logged base rate (rates.arm_hz)"
            )
        if s + 1 > self.inputs.last_step:
            raise EndOfLog(s + 1)
        self.server.step = s + 1

    def ground_truth(self) -> dict | None:
        return None

    def truth_brief(self) -> dict | None:
        return None

    def pylog_records(self) -> list[tuple[str, str, str]]:
        """The drivers' logging records the run drained here (see :class:`mission.replay.record.RecordingLogCapture`)."""
        return self.server.pylog()
