"""Record at the device boundary, serve back: the same calls get the same results
(values, None, exceptions), operator commands come at their drain, the log's end
stops the replay, and an open-loop what-if gets the latest reading, never a future one.

The devices here are small stand-ins whose readings change on every call: the
recording and serving logic is what is under test (the end-to-end tests replay
real simulator and protocol-peer runs)."""

from __future__ import annotations

import math

import numpy as np
import orjson
import pytest

from hal.interfaces import Arm, Backend, DeviceSet, Health, HealthState, JointState, NavigationState, Vehicle
from mission.logs.writer import encode_json
from mission.replay.record import RecordingBackend, RecordingQueue
from mission.replay.schema import record_steps
from mission.replay.serve import EndOfLog, ReplayBackend, ReplayGap, ReplayInputs, ReplayStop
from mission.runtime.operator import CommandQueue


class MemoryLog:
    """Collects messages as the run log writer would encode them."""

    def __init__(self) -> None:
        self.topics: dict[str, list[dict]] = {}
        self.path = "memory.mcap"

    def write(self, topic: str, t: float, msg: dict) -> None:
        msg["t"] = t
        self.topics.setdefault(topic, []).append(orjson.loads(encode_json(msg)))

    def messages(self, topic: str) -> list[dict]:
        return self.topics.get(topic, [])


class Clock:
    def __init__(self) -> None:
        self.t = 0.0

    def now(self) -> float:
        self.t += 0.001  # a wall clock: every reading differs
        return self.t


class FakeVehicle(Vehicle):
    name = "fake_vehicle"

    def __init__(self, clock: Clock) -> None:
        self.clock = clock
        self.n = 0
        self.sent: list = []
        self.fail_nav_at: set[int] = set()

    def arm(self) -> None: ...
    def disarm(self) -> None: ...

    @property
    def armed(self) -> bool:
        return True

    def command_body_velocity(self, v) -> None:
        if np.any(np.asarray(v) > 1.0):
            raise ValueError(f"refused {float(np.max(v))} m/s")
        self.sent.append(np.array(v))

    def navigation(self) -> NavigationState:
        self.n += 1
        if self.n in self.fail_nav_at:
            raise TimeoutError("no ATTITUDE for 0.5 s")
        vel = None if self.n % 3 == 0 else np.full(6, 0.01 * self.n)
        return NavigationState(
            t=self.clock.t,
            position=np.array([self.n, 0.0, 2.0]),
            attitude=np.zeros(3),
            body_velocity=vel,
            velocity_t=None if vel is None else self.clock.t,
            depth=2.0,
            altitude=None if self.n % 2 else 3.0,
        )

    def health(self) -> Health:
        return Health(HealthState.OK, 0.0, "")  # unchanged: recorded once


class FakeArm(Arm):
    name = "fake_arm"
    joint_names = ("a", "b")

    def __init__(self) -> None:
        self.n = 0

    def enable(self) -> None: ...
    def disable(self) -> None: ...
    def command_joint_velocity(self, qdot) -> None: ...

    def joint_state(self) -> JointState:
        self.n += 1
        return JointState(
            t=float(self.n), position=np.array([0.1 * self.n, -0.0]), velocity=np.zeros(2), current=np.zeros(2)
        )

    def health(self) -> Health:
        if self.n > 4:
            return Health(HealthState.FAULT, 5.0, "overcurrent")
        return Health(HealthState.OK, 0.0, "")


class FakeBackend(Backend):
    def __init__(self) -> None:
        self.clock = Clock()
        self.devices = DeviceSet(vehicle=FakeVehicle(self.clock), arm=FakeArm())

    def advance(self, dt: float) -> None:
        self.clock.t += dt


def script(backend, queue, steps: int = 6) -> list:
    """A fixed pattern of calls, like a supervisor's; returns what each call gave."""
    out: list = []
    devs = backend.devices

    def call(fn):
        try:
            out.append(("ok", fn()))
        except Exception as exc:  # noqa: BLE001
            out.append(("raised", type(exc).__name__, str(exc), isinstance(exc, TimeoutError)))

    backend.open()
    for s in range(steps):
        call(backend.clock.now)
        call(devs.vehicle.navigation)
        call(devs.vehicle.navigation)  # twice in a step: a different reading
        call(devs.arm.joint_state)
        call(devs.vehicle.health)
        call(devs.arm.health)
        out.append(("drain", queue.drain()))
        call(lambda s=s: devs.vehicle.command_body_velocity(np.full(6, 0.5 * s)))  # refused from s = 3
        call(backend.clock.now)
        backend.advance(0.01)
    call(backend.clock.now)
    backend.close()
    return out


def same(a, b) -> bool:
    if isinstance(a, (NavigationState, JointState)):
        return all(same(getattr(a, f), getattr(b, f)) for f in a.__dataclass_fields__)
    if isinstance(a, np.ndarray) or isinstance(b, np.ndarray):
        return (
            a is not None
            and b is not None
            and np.array_equal(a, b, equal_nan=True)
            and np.array_equal(np.signbit(a), np.signbit(b))
        )
    if isinstance(a, tuple):
        return len(a) == len(b) and all(same(x, y) for x, y in zip(a, b))
    if isinstance(a, list):
        return len(a) == len(b) and all(same(x, y) for x, y in zip(a, b))
    return a == b


@pytest.fixture
def recorded():
    live = FakeBackend()
    live.devices.vehicle.fail_nav_at = {5}
    log = MemoryLog()
    rec = RecordingBackend(live, log)
    inner_queue = CommandQueue()
    queue = RecordingQueue(inner_queue, rec)
    inner_queue.put("pause", "key 'p'")
    original = script(rec, _QueueFeeder(queue, inner_queue))
    return log, original


class _QueueFeeder:
    """Puts a resume in the queue before the drain of step 3 (an operator key press)."""

    def __init__(self, queue, inner) -> None:
        self.queue, self.inner, self.n = queue, inner, 0

    def drain(self):
        self.n += 1
        if self.n == 4:
            self.inner.put("resume", "key 'r'")
        return self.queue.drain()


def test_replay_gives_every_call_the_recorded_result(recorded):
    log, original = recorded
    inputs = ReplayInputs.from_log(log)
    assert inputs.last_step == 6
    replay = ReplayBackend(inputs)
    from mission.replay.run import ReplayQueue

    again = script(replay, ReplayQueue(replay))
    assert len(again) == len(original)
    for i, (a, b) in enumerate(zip(original, again)):
        assert same(a, b), (i, a, b)
    kinds = [x[0] for x in original]
    assert kinds.count("raised") == 4  # one navigation timeout, three refused commands
    assert ("drain", [("pause", "key 'p'")]) in original and ("drain", [("resume", "key 'r'")]) in original


def test_unchanged_results_are_recorded_once(recorded):
    log, _ = recorded
    calls = [r["call"] for m in record_steps(log) for r in m["reads"]]
    assert calls.count("vehicle.health") == 1
    assert calls.count("arm.health") == 2  # ok, then the fault
    assert calls.count("clock.now") == 6 * 2 + 1


def test_end_of_log_stops_the_replay(recorded):
    log, _ = recorded
    replay = ReplayBackend(ReplayInputs.from_log(log))
    for _ in range(6):
        replay.advance(0.01)
    with pytest.raises(EndOfLog) as end:
        replay.advance(0.01)
    assert end.value.step == 7 and not isinstance(end.value, Exception)


def test_open_loop_reads_get_the_latest_reading_never_a_future_one(recorded):
    log, _ = recorded
    replay = ReplayBackend(ReplayInputs.from_log(log))
    devs = replay.devices
    first = devs.arm.joint_state()
    assert first.t == 1.0
    assert devs.arm.joint_state().t == 1.0  # a second call the run did not make: the latest reading
    replay.advance(0.01)
    replay.advance(0.01)
    assert devs.arm.joint_state().t == 3.0
    replay.inputs.steps[2]["dt"] = 0.02  # as if the log had another base rate
    with pytest.raises(ReplayStop, match="base rate"):
        replay.advance(0.01)


def test_a_reading_the_run_never_made_is_a_gap():
    log = MemoryLog()
    rec = RecordingBackend(FakeBackend(), log)
    rec.clock.now()
    rec.close()
    replay = ReplayBackend(ReplayInputs.from_log(log))
    with pytest.raises(ReplayGap, match="vehicle.navigation"):
        replay.devices.vehicle.navigation()


def test_devices_that_could_not_be_opened_fail_the_same_way():
    class Unplugged(FakeBackend):
        def open(self) -> None:
            raise OSError("[Errno 19] No such device: 'can0'")

    log = MemoryLog()
    rec = RecordingBackend(Unplugged(), log)
    with pytest.raises(OSError) as live:
        rec.open()
    rec.close()
    replay = ReplayBackend(ReplayInputs.from_log(log))
    with pytest.raises(OSError) as again:
        replay.open()
    assert str(again.value) == str(live.value) and type(again.value).__name__ == "OSError"


class ResettableArm(FakeArm):
    """A drive-backed arm: it also has the CANopen driver's own ``reset_faults``."""

    def reset_faults(self) -> list[str]:
        return ["j2: EMCY 0x2310 (continuous over-current)"]


def test_driver_methods_and_driver_warnings_are_recorded_and_served():
    import logging

    from hal.interfaces import EngageRefused

    backend = FakeBackend()
    backend.devices.arm = ResettableArm()
    backend.devices.vehicle.arm = lambda: (_ for _ in ()).throw(EngageRefused("PreArm: Leak detected"))
    log = MemoryLog()
    rec = RecordingBackend(backend, log)

    def session(b, capture) -> list:
        out = []
        with capture as cap:
            if getattr(b, "inner", None) is not None and getattr(b.inner, "pylog_records", None) is None:
                logging.getLogger("canopen.node").warning("heartbeat of node 3 lost")
            out.append(hasattr(b.devices.arm, "reset_faults") and b.devices.arm.reset_faults())
            out.append(hasattr(b.devices.vehicle, "reset_faults"))
            try:
                b.devices.vehicle.arm()
            except EngageRefused as exc:  # the supervisor catches exactly this type
                out.append(("refused", str(exc)))
            cap.drain()
        return out

    events: list = []
    live = session(rec, rec.log_capture(lambda *a, **kw: events.append((a, kw))))
    rec.close()
    replay = RecordingBackend(ReplayBackend(ReplayInputs.from_log(log)), MemoryLog())
    events_again: list = []
    again = session(replay, replay.log_capture(lambda *a, **kw: events_again.append((a, kw))))
    assert live == again == [["j2: EMCY 0x2310 (continuous over-current)"], False, ("refused", "PreArm: Leak detected")]
    assert events == events_again and events[0][0] == ("python_log", "canopen.node: heartbeat of node 3 lost")


class OddArm(FakeArm):
    """Non-finite readings, and readings equal by ``==`` that differ in the sign of a zero."""

    def joint_state(self) -> JointState:
        self.n += 1
        pos = {1: [0.0, 1.0], 2: [-0.0, 1.0], 3: [math.nan, -math.inf], 4: [math.nan, -math.inf]}.get(
            self.n, [0.5, 0.5]
        )
        return JointState(t=0.0, position=np.array(pos), velocity=np.array([math.inf, -0.0]), current=np.zeros(2))


def test_non_finite_and_signed_zero_readings_replay_exactly():
    live = FakeBackend()
    live.devices = DeviceSet(vehicle=live.devices.vehicle, arm=OddArm())
    log = MemoryLog()
    rec = RecordingBackend(live, log)
    queue = CommandQueue()
    original = script(rec, RecordingQueue(queue, rec))
    replay = ReplayBackend(ReplayInputs.from_log(log))
    from mission.replay.run import ReplayQueue

    again = script(replay, ReplayQueue(replay))
    for i, (a, b) in enumerate(zip(original, again)):
        assert same(a, b), (i, a, b)
    reads = [r for m in record_steps(log) for r in m["reads"] if r["call"] == "arm.joint_state"]
    assert len(reads) == 5  # 0.0 then -0.0 (equal by ==, not the same reading), NaN twice (NaN != NaN), 0.5
    assert any("nonfinite" in r for r in reads)
