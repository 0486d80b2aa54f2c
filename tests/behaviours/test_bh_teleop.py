"""The teleop leaf tick by tick, on the simulator's devices with a recording stand-in
for the controller: what it sends the KCL for each command, the dead-man, commands too
old, goals from before it started, mode requests, the ways to hand back; and the frames
clicks come in (hypothesis)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from py_trees.common import Status

from behaviours.operator_frames import UnknownFrame, to_world
from behaviours.predicates import PredicateEval
from behaviours.teleop import HandBack, Teleop, TeleopSettings
from hal.interfaces import NavigationState
from mission.spec import Predicate

KNOWN = (
    "survey",
    "grasp",
    "transport",
    "hold",
    "jog_tool",
    "jog_tool_vehicle",
    "jog_vehicle",
    "lift",
    "reach",
    "look_at",
)


def _leaf(ctx, **kw) -> Teleop:
    ctx.controller.known = KNOWN
    return Teleop("Operator", ctx, TeleopSettings(**kw))


def _velocity_targets(ctx, key: str) -> list[np.ndarray]:
    return [np.asarray(c[1][key]) for c in ctx.controller.calls if c[0] == "set_targets" and key in c[1]]


def test_a_fresh_command_drives_and_the_dead_man_zeroes_it(make_ctx, tick):
    ctx = make_ctx()
    fox = ctx.devices.operators["foxglove"]
    leaf = _leaf(ctx, modes=("vehicle_velocity",), inputs=("foxglove",), deadman_s=0.5)
    leaf.tick_once()
    assert ctx.controller.action == "jog_vehicle"
    fox.push_velocity([0.2, 0, 0, 0, 0, 0])
    leaf.tick_once()
    assert np.allclose(_velocity_targets(ctx, "vehicle_velocity")[-1], [0.2, 0, 0, 0, 0, 0])
    ctx.advance(0.4)
    leaf.tick_once()  # 0.4 s old: still acting
    assert np.allclose(_velocity_targets(ctx, "vehicle_velocity")[-1], [0.2, 0, 0, 0, 0, 0])
    ctx.advance(0.2)
    leaf.tick_once()  # 0.6 s old: the dead-man
    assert np.all(_velocity_targets(ctx, "vehicle_velocity")[-1] == 0)
    kinds = [(e["kind"], e.get("role")) for e in ctx.events.events if e["kind"] == "teleop_input"]
    assert kinds == [("teleop_input", "foxglove"), ("teleop_input", None)]
    assert ctx.operator.status["input"] is None and ctx.operator.status["command"] == [0.0] * 6


def test_a_command_arriving_too_old_is_dropped_and_said_once(make_ctx):
    ctx = make_ctx()
    fox = ctx.devices.operators["foxglove"]
    leaf = _leaf(ctx, modes=("tool_velocity",), frame="world", inputs=("foxglove",), deadman_s=0.5)
    ctx.advance(5.0)
    leaf.tick_once()
    assert ctx.controller.action == "jog_tool"
    for _ in range(3):
        fox.push_velocity([0.0, 0.1, 0, 0, 0, 0], sent=ctx.now() - 2.0)  # 2 s on the way
        leaf.tick_once()
        ctx.advance(0.1)
    assert all(np.all(v == 0) for v in _velocity_targets(ctx, "tool_velocity"))
    dropped = [e for e in ctx.events.events if e["kind"] == "teleop_dropped"]
    assert len(dropped) == 1 and dropped[0]["age_s"] == pytest.approx(2.0)
    assert ctx.operator.status["dropped"] == 1


def test_goals_given_before_the_leaf_started_are_not_used(make_ctx):
    ctx = make_ctx()
    fox = ctx.devices.operators["foxglove"]
    fox.push_point([10.0, 6.0, 2.0], "world")  # a click from an earlier session
    ctx.advance(1.0)
    leaf = _leaf(ctx, modes=("vehicle_goal",), inputs=("foxglove",))
    leaf.tick_once()
    leaf.tick_once()
    assert ctx.controller.action == "hold"  # a goal mode without a goal holds still
    assert "vehicle_goal" not in ctx.controller.targets
    fox.push_point([11.0, 6.5, 2.0], "world")
    leaf.tick_once()
    assert ctx.controller.action == "lift"
    x, y, z, yaw = ctx.controller.targets["vehicle_goal"]
    assert (x, y, z) == (11.0, 6.5, 2.0)
    assert yaw == pytest.approx(float(ctx.devices.vehicle.navigation().attitude[2]))  # heading kept


def test_mode_requests_switch_within_the_nodes_modes_only(make_ctx):
    ctx = make_ctx()
    fox = ctx.devices.operators["foxglove"]
    leaf = _leaf(ctx, modes=("vehicle_velocity", "tool_velocity"), inputs=("foxglove",), frame="vehicle")
    leaf.tick_once()
    fox.press("mode:point_at")
    leaf.tick_once()
    assert ctx.controller.action == "jog_vehicle"
    assert any(e["kind"] == "teleop_refused" and "point_at" in e["message"] for e in ctx.events.events)
    fox.press("mode:next")
    leaf.tick_once()
    assert ctx.controller.action == "jog_tool_vehicle"
    fox.press("frame:toggle")
    leaf.tick_once()
    assert ctx.controller.action == "jog_tool"
    modes = [e["message"] for e in ctx.events.events if e["kind"] == "teleop_mode"]
    assert modes[0] == "mode vehicle_velocity -> tool_velocity (foxglove)" and "world axes" in modes[1]


def test_hand_back_by_button_service_or_condition_as_the_node_allows(make_ctx):
    ctx = make_ctx()
    fox = ctx.devices.operators["foxglove"]
    leaf = _leaf(ctx, inputs=("foxglove",), handback=HandBack(button=False, service=True))
    leaf.tick_once()
    fox.press("handback")  # this node takes no button
    assert leaf.tick_once() is None and leaf.status == Status.RUNNING
    fox.press("service:handback")
    leaf.tick_once()
    assert leaf.status == Status.SUCCESS and ctx.controller.action == "hold"
    assert ctx.operator.status is None
    who = [e["who"] for e in ctx.events.events if e["kind"] == "control"]
    assert who == ["operator", "autonomy"]

    ctx2 = make_ctx(types={"attempts": "int"}, initial={"attempts": 0})
    until = PredicateEval.from_spec(Predicate("blackboard", {"key": "attempts", "op": "at_least", "value": 1}, None))
    leaf2 = _leaf(ctx2, inputs=("foxglove",), handback=HandBack(button=False, service=False, until=until))
    leaf2.tick_once()
    assert leaf2.status == Status.RUNNING
    ctx2.blackboard.set("attempts", 1)
    leaf2.tick_once()
    assert leaf2.status == Status.SUCCESS


def test_no_operator_input_fails_at_once_and_a_timeout_stops_the_motion(make_ctx):
    ctx = make_ctx()
    leaf = _leaf(ctx, inputs=("joystick",))
    leaf.tick_once()
    assert leaf.status == Status.FAILURE and "no operator input joystick" in leaf.feedback_message
    leaf2 = _leaf(ctx, inputs=("gamepad",), timeout_s=1.0)
    leaf2.tick_once()
    ctx.advance(1.0)
    stops = ctx.motion_stops
    leaf2.tick_once()
    assert leaf2.status == Status.FAILURE and ctx.motion_stops == stops + 1


# --------------------------------------------------------------------------- frames


def _nav(x, y, z, roll, pitch, yaw) -> NavigationState:
    return NavigationState(0.0, np.array([x, y, z]), np.array([roll, pitch, yaw]), None, None, z, 2.0)


coords = st.floats(-20, 20, allow_nan=False)
angles = st.floats(-math.pi, math.pi, allow_nan=False)


@settings(max_examples=60, deadline=None)
@given(coords, coords, coords, coords, coords, angles)
def test_a_ground_plane_click_gives_north_east_and_heading_in_the_world(n, e, vx, vy, vz, psi):
    """``map`` is ENU (x east, y north, z up); ``vehicle_level`` is map's axes at the vehicle.
    A pose's heading about map's up axis, from east, is pi/2 minus the world yaw."""
    nav = _nav(vx, vy, abs(vz), 0.1, -0.05, 0.7)
    T = np.eye(4)
    T[:3, :3] = [[math.cos(psi), -math.sin(psi), 0], [math.sin(psi), math.cos(psi), 0], [0, 0, 1]]
    T[:3, 3] = [e, n, 0.0]
    wp = to_world(T, "map", nav)
    assert wp.position[:2] == pytest.approx([n, e]) and not wp.depth_given
    assert math.remainder(wp.yaw - (math.pi / 2 - psi), 2 * math.pi) == pytest.approx(0.0, abs=1e-9)
    wl = to_world(np.array([e, n, 0.0]), "vehicle_level", nav)
    assert wl.position == pytest.approx([vx + n, vy + e, abs(vz)]) and wl.yaw is None


@settings(max_examples=60, deadline=None)
@given(coords, coords, coords, angles, angles, angles)
def test_a_point_in_the_vehicle_frame_goes_through_its_attitude(px, py, pz, roll, pitch, yaw):
    roll, pitch = roll / 4, pitch / 4
    nav = _nav(3.0, 4.0, 2.0, roll, pitch, yaw)
    wp = to_world(np.array([px, py, pz]), "base_link", nav)
    back = to_world(wp.position, "world", nav)
    assert back.depth_given and back.position == pytest.approx(wp.position)
    # the distance from the vehicle is the point's norm in its frame
    assert np.linalg.norm(wp.position - [3.0, 4.0, 2.0]) == pytest.approx(np.linalg.norm([px, py, pz]), abs=1e-9)


def test_a_click_in_an_unknown_frame_is_refused():
    with pytest.raises(UnknownFrame, match="frame `camera_link`"):
        to_world(np.zeros(3), "camera_link", _nav(0, 0, 1, 0, 0, 0))
