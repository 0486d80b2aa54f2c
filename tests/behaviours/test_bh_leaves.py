"""Tick tests of the small leaves (wait, set, log, condition, gripper) and the
clock timeout, on the simulator's devices and clock."""

from __future__ import annotations

import numpy as np
import py_trees
import pytest
from py_trees.common import Status

from behaviours.blackboard_set import SetBlackboard
from behaviours.condition import Condition
from behaviours.context import BlackboardTypeError, MissionBlackboard
from behaviours.gripper import GripperCommand
from behaviours.log_event import LogEvent
from behaviours.predicates import PredicateEval, telemetry_converged
from behaviours.timeout import ClockTimeout
from behaviours.wait import Wait
from hal.interfaces import Gripper, GripperMotion, GripperState, Health, HealthState


def test_wait_follows_the_backend_clock(make_ctx, tick):
    ctx = make_ctx()
    leaf = Wait("w", ctx, 1.5)
    assert tick(leaf, ctx, max_s=5.0, dt=0.1) == Status.SUCCESS
    assert 1.5 <= ctx.now() <= 1.6


def test_set_writes_adds_and_rejects_wrong_types(make_ctx):
    ctx = make_ctx({"n": "int", "mode": "str", "gain": "float"}, {"n": 1})
    SetBlackboard("s", ctx, "n", add=2).tick_once()
    assert ctx.blackboard.get("n") == 3 and isinstance(ctx.blackboard.get("n"), int)
    leaf = SetBlackboard("s", ctx, "gain", add=0.5)
    leaf.tick_once()
    assert leaf.status == Status.SUCCESS and ctx.blackboard.get("gain") == 0.5  # unset counts as 0
    bad = SetBlackboard("s", ctx, "mode", value=3)
    bad.tick_once()
    assert bad.status == Status.FAILURE and "blackboard_error" in ctx.events.kinds()
    assert not ctx.blackboard.is_set("mode")


def test_blackboard_types_are_enforced_and_poses_frozen():
    bb = MissionBlackboard({"p": "pose", "pt": "point", "flag": "bool"})
    with pytest.raises(BlackboardTypeError):
        bb.set("p", np.eye(3))
    with pytest.raises(BlackboardTypeError):
        bb.set("pt", [0.0, np.nan, 1.0])
    with pytest.raises(KeyError):
        bb.set("nope", 1)
    bb.set("p", np.eye(4))
    assert not bb.get("p").flags.writeable
    bb.set("flag", True)
    assert bb.snapshot() == {"p": np.eye(4).tolist(), "flag": True}
    other = MissionBlackboard({"p": "pose"})
    assert other.is_set("p") is False and bb.is_set("p")  # each blackboard has its own values
    bb.release()
    assert not py_trees.blackboard.Blackboard.exists(f"{bb.namespace}/p")


def test_log_emits_an_event(make_ctx):
    ctx = make_ctx()
    leaf = LogEvent("Log", ctx, "hello", "warning")
    leaf.tick_once()
    assert leaf.status == Status.SUCCESS
    assert ctx.events.events[-1] == {
        "kind": "mission_log",
        "message": "hello",
        "node": "Log",
        "level": "warning",
        "t": 0.0,
    }


def test_depth_and_altitude_conditions_read_navigation(make_ctx):
    ctx = make_ctx()
    nav = ctx.devices.vehicle.navigation()
    cases = [
        ("depth_m", {"min": None, "max": nav.depth + 0.5}, Status.SUCCESS),
        ("depth_m", {"min": nav.depth + 0.5, "max": None}, Status.FAILURE),
        ("altitude_m", {"min": nav.altitude - 0.5, "max": nav.altitude + 0.5}, Status.SUCCESS),
        ("altitude_m", {"min": None, "max": nav.altitude - 0.5}, Status.FAILURE),
    ]
    for kind, params, expected in cases:
        leaf = Condition("c", ctx, PredicateEval(kind, params))
        leaf.tick_once()
        assert leaf.status == expected, (kind, params, leaf.feedback_message)


def test_force_condition_reads_the_wrench_sensor(make_ctx):
    ctx = make_ctx()
    if ctx.devices.wrench_sensor is not None:  # the simulated wrist sensor, at rest: small force
        assert PredicateEval("force_n", {"min": None, "max": 10.0}).holds(ctx)[0] is True
        assert PredicateEval("force_n", {"min": 10.0, "max": None}).holds(ctx)[0] is False
    ctx.devices = type(ctx.devices)(ctx.devices.vehicle, ctx.devices.arm)  # no sensor at all
    ok, detail = PredicateEval("force_n", {"min": 10.0, "max": None}).holds(ctx)
    assert not ok and "unknown" in detail


@pytest.mark.parametrize(
    "op,ref,expected",
    [
        ("equals", 2, True),
        ("not_equals", 2, False),
        ("below", 3, True),
        ("above", 2, False),
        ("at_most", 2, True),
        ("at_least", 3, False),
    ],
)
def test_blackboard_comparisons(make_ctx, op, ref, expected):
    ctx = make_ctx({"n": "int", "unset": "int"}, {"n": 2})
    assert PredicateEval("blackboard", {"key": "n", "op": op, "value": ref}).holds(ctx)[0] is expected
    assert PredicateEval("blackboard", {"key": "unset", "op": op, "value": ref}).holds(ctx)[0] is False
    assert PredicateEval("blackboard", {"key": "unset", "op": "is_set", "value": False}).holds(ctx)[0] is True


def test_telemetry_convergence_reads_the_controller_fields():
    base = {"action": "grasp", "stopped": False, "transition_progress": 1.0, "convergence": 0.01}
    assert telemetry_converged(base)
    assert telemetry_converged(base, "grasp")
    assert not telemetry_converged(base, "hold")  # another action's convergence
    assert not telemetry_converged({**base, "convergence": 0.05})
    assert telemetry_converged({**base, "convergence": 0.05}, max_error=0.1)
    assert not telemetry_converged({**base, "convergence": None})  # not evaluated yet
    assert not telemetry_converged({**base, "transition_progress": 0.5})
    assert not telemetry_converged({**base, "stopped": True})
    assert not telemetry_converged({})


def test_detected_requires_fresh_confident_detection(make_ctx):
    ctx = make_ctx()
    assert PredicateEval("detected", {"min_confidence": 0.5, "max_age_s": 1.0, "store_as": None}).holds(ctx) == (
        False,
        "no fresh detection",
    )


def test_gripper_preshape_then_close_on_nothing(make_ctx, tick):
    ctx = make_ctx()
    pre = GripperCommand("Preshape", ctx, "preshape", shape="cylindrical", timeout_s=5)
    assert tick(pre, ctx, max_s=5) == Status.SUCCESS
    close = GripperCommand("Close", ctx, "close", current_limit_a=1.0, timeout_s=20)
    assert tick(close, ctx, max_s=20) == Status.SUCCESS
    assert ctx.devices.gripper.state().motion == GripperMotion.STOPPED  # end of travel: nothing in the hand
    assert PredicateEval("grasp_detected", {"current_a": 0.8, "min_groups": 1}).holds(ctx)[0] is False


def test_gripper_timeout_and_fault_fail(make_ctx, tick):
    ctx = make_ctx()
    close = GripperCommand("Close", ctx, "close", current_limit_a=1.0, timeout_s=0.5)
    assert tick(close, ctx, max_s=5) == Status.FAILURE and "timed out" in close.feedback_message
    ctx.advance(0.1)
    assert ctx.devices.gripper.state().motion != GripperMotion.CLOSING  # stopped on failure
    ctx.sim.inject("gripper_fault")
    ctx.advance(0.1)
    opening = GripperCommand("Open", ctx, "open", timeout_s=5)
    assert tick(opening, ctx, max_s=5) == Status.FAILURE
    assert "fault" in opening.feedback_message


def test_unknown_preshape_fails_cleanly(make_ctx):
    ctx = make_ctx()
    leaf = GripperCommand("Preshape", ctx, "preshape", shape="spherical")
    leaf.tick_once()
    assert leaf.status == Status.FAILURE and "spherical" in leaf.feedback_message


def test_interrupted_gripper_stops_the_motors(make_ctx, tick):
    ctx = make_ctx()
    close = GripperCommand("Close", ctx, "close", current_limit_a=1.0, timeout_s=20)
    tick(close, ctx, max_s=1.0)
    assert ctx.devices.gripper.state().motion == GripperMotion.CLOSING
    close.stop(Status.INVALID)
    ctx.advance(0.1)
    assert ctx.devices.gripper.state().motion != GripperMotion.CLOSING
    assert "halted" in ctx.events.kinds()


class HoldingGripper(Gripper):
    """A gripper whose state is set by the test (no simulated hand can hold yet without an arm controller)."""

    def __init__(self, motion, currents):
        self.motion, self.currents = motion, np.asarray(currents, float)

    def health(self):
        return Health(HealthState.OK, 0.0)

    def preshape(self, shape): ...
    def close(self, current_limit): ...
    def open(self): ...
    def stop(self): ...

    def state(self):
        return GripperState(0.0, np.zeros(3), self.currents, self.motion)


@pytest.mark.parametrize(
    "motion,currents,min_groups,expected",
    [
        (GripperMotion.HOLDING, [1.0, 0.9, 0.1], 2, True),
        (GripperMotion.HOLDING, [1.0, 0.5, 0.1], 2, False),
        (GripperMotion.CLOSING, [1.0, 1.0, 1.0], 1, False),
        (GripperMotion.HOLDING, [0.2, 0.2, 0.2], 1, False),
    ],
)
def test_grasp_detected_needs_holding_and_currents(make_ctx, motion, currents, min_groups, expected):
    ctx = make_ctx()
    ctx.devices = type(ctx.devices)(ctx.devices.vehicle, ctx.devices.arm, gripper=HoldingGripper(motion, currents))
    assert PredicateEval("grasp_detected", {"current_a": 0.8, "min_groups": min_groups}).holds(ctx)[0] is expected


def test_clock_timeout_halts_a_running_child(make_ctx, tick):
    ctx = make_ctx()
    child = Wait("long", ctx, 100.0)
    root = ClockTimeout("limit", child, ctx, 1.0)
    assert tick(root, ctx, max_s=5.0) == Status.FAILURE
    assert child.status == Status.INVALID and 1.0 <= ctx.now() <= 1.1
    assert "timeout" in ctx.events.kinds()
    quick = ClockTimeout("limit", Wait("short", ctx, 0.3), ctx, 1.0)
    assert tick(quick, ctx, max_s=5.0) == Status.SUCCESS
