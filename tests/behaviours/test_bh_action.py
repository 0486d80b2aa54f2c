"""KclAction tick tests on the simulator: action switching, targets, waypoints,
detection tracking, timeout, faults, and the halt contract."""

from __future__ import annotations

import numpy as np
import py_trees
from py_trees.common import Status

from behaviours.action import KclAction, resolve_goal
from behaviours.predicates import PredicateEval
from kcl.rotations import rpy_to_matrix


def drive_vehicle(ctx) -> None:
    """Stand-in for the supervisor's vehicle loop: P-law toward the controller's
    vehicle goal (body frame), nothing when stopped."""
    g = ctx.controller.targets.get("vehicle_goal")
    if g is None or ctx.controller.stopped:
        return
    nav = ctx.devices.vehicle.navigation()
    R = rpy_to_matrix(*nav.attitude)
    v_lin = np.clip(R.T @ (0.5 * (np.array(g[:3]) - nav.position)), -0.3, 0.3)
    yaw_err = (g[3] - nav.attitude[2] + np.pi) % (2 * np.pi) - np.pi
    ctx.devices.vehicle.command_body_velocity(np.r_[v_lin, 0.0, 0.0, 0.5 * yaw_err])


def test_resolve_goal_keeps_missing_fields_and_uses_altitude():
    prev = (1.0, 2.0, 3.0, 0.5)
    assert resolve_goal({"down_m": 0.3}, prev, 3.0, 2.0) == (1.0, 2.0, 0.3, 0.5)
    x, y, z, yaw = resolve_goal({"north_m": 5.0, "altitude_m": 1.5, "yaw_deg": 90}, prev, depth=3.0, altitude=2.0)
    assert (x, y) == (5.0, 2.0) and abs(z - 3.5) < 1e-12 and abs(yaw - np.pi / 2) < 1e-12
    assert resolve_goal({"altitude_m": 1.0}, prev, 3.0, None)[2] == 3.0  # altitude unknown: keep z


def test_action_switches_controller_and_succeeds_on_convergence(make_ctx):
    ctx = make_ctx()
    leaf = KclAction("Transport", ctx, "transport", timeout_s=10)
    leaf.tick_once()
    assert leaf.status == Status.RUNNING
    assert ctx.controller.calls[0] == ("set_action", "transport", 0.0)
    ctx.advance(0.5)
    leaf.tick_once()
    assert leaf.status == Status.RUNNING
    ctx.controller.converged = True
    leaf.tick_once()
    assert leaf.status == Status.SUCCESS
    assert ctx.motion_stops == 0 and not ctx.controller.stopped  # success keeps the action running
    assert ctx.events.kinds() == ["action_start", "action_success"]


def test_convergence_of_the_previous_action_is_not_taken(make_ctx):
    ctx = make_ctx()
    leaf = KclAction("Hold", ctx, "hold", timeout_s=10)
    leaf.tick_once()
    ctx.controller.action = "grasp"  # telemetry still reports another action
    ctx.controller.converged = True
    leaf.tick_once()
    assert leaf.status == Status.RUNNING


def test_timeout_fails_and_stops_motion(make_ctx, tick):
    ctx = make_ctx()
    leaf = KclAction("Grasp", ctx, "grasp", timeout_s=1.0)
    assert tick(leaf, ctx, max_s=3.0) == Status.FAILURE
    assert 1.0 <= ctx.now() < 1.3
    assert ctx.motion_stops == 1 and ctx.controller.stopped
    assert "timed out" in leaf.feedback_message


def test_lasting_controller_fault_fails_the_action(make_ctx):
    ctx = make_ctx()
    leaf = KclAction("Grasp", ctx, "grasp", timeout_s=10)
    leaf.tick_once()
    ctx.controller.fault = "joint 3 velocity NaN"
    leaf.tick_once()
    assert leaf.status == Status.RUNNING  # a one-step fault may clear at the next step
    ctx.advance(KclAction.fault_grace_s)
    leaf.tick_once()
    assert leaf.status == Status.FAILURE and "joint 3 velocity NaN" in leaf.feedback_message
    assert ctx.motion_stops == 1


def test_transient_controller_fault_is_tolerated(make_ctx):
    ctx = make_ctx()
    leaf = KclAction("Grasp", ctx, "grasp", timeout_s=10)
    leaf.tick_once()
    ctx.controller.fault = "solver"
    leaf.tick_once()
    ctx.controller.fault = None
    leaf.tick_once()  # a good step clears it
    ctx.advance(1.0)
    ctx.controller.fault = "solver"
    leaf.tick_once()
    assert leaf.status == Status.RUNNING


def test_interrupted_action_zeroes_velocities_before_returning(make_ctx, tick):
    ctx = make_ctx()
    ctx.devices.vehicle.arm()
    leaf = KclAction("Survey", ctx, "survey", targets={"vehicle_goal": {"north_m": 30.0}}, timeout_s=100)
    tick(leaf, ctx, max_s=1.0, step=drive_vehicle)
    assert leaf.status == Status.RUNNING
    assert np.any(np.abs(ctx.sim.ground_truth()["vehicle"]["commanded_velocity"]) > 0.01)
    leaf.stop(Status.INVALID)
    assert ctx.motion_stops == 1 and ctx.controller.stopped
    assert ctx.sim.ground_truth()["vehicle"]["commanded_velocity"] == [0.0] * 6
    assert "halted" in ctx.events.kinds()
    leaf.stop(Status.INVALID)  # not running any more: no second stop
    assert ctx.motion_stops == 1


def test_waypoints_are_followed_in_order_then_succeed(make_ctx, tick):
    ctx = make_ctx()
    ctx.devices.vehicle.arm()
    start = ctx.devices.vehicle.navigation().position.copy()
    wps = [
        {"north_m": start[0] + 1.0, "east_m": start[1], "down_m": 2.0, "yaw_deg": None, "altitude_m": None},
        {"north_m": start[0] + 1.0, "east_m": start[1] + 1.0, "down_m": None, "yaw_deg": None, "altitude_m": None},
    ]
    leaf = KclAction("Go", ctx, "survey", targets={"waypoints": wps, "tolerance_m": 0.2}, timeout_s=60)
    assert tick(leaf, ctx, max_s=60, step=drive_vehicle) == Status.SUCCESS
    goals = [c[1]["vehicle_goal"] for c in ctx.controller.calls if c[0] == "set_targets" and "vehicle_goal" in c[1]]
    assert len(goals) == 2 and goals[1][2] == 2.0  # the second waypoint keeps the first one's depth
    pos = ctx.devices.vehicle.navigation().position
    assert np.linalg.norm(pos - np.array(goals[1][:3])) <= 0.2
    assert "waypoint" in ctx.events.kinds()


def test_survey_until_detected_stores_world_grasp_pose(make_ctx, tick):
    ctx = make_ctx({"grasp_pose": "pose"}, seed=3)
    ctx.devices.vehicle.arm()
    pipe = ctx.sim.pipe_grasp_pose()
    wp = {"north_m": pipe[0, 3] - 1.8, "east_m": pipe[1, 3] - 0.2, "altitude_m": 2.0, "yaw_deg": 0.0, "down_m": None}
    until = PredicateEval("detected", {"min_confidence": 0.5, "max_age_s": 0.5, "store_as": "grasp_pose"})
    leaf = KclAction(
        "Survey", ctx, "survey", targets={"waypoints": [wp], "tolerance_m": 0.3}, until=until, timeout_s=60
    )
    assert tick(leaf, ctx, max_s=60, step=drive_vehicle) == Status.SUCCESS
    stored = ctx.blackboard.get("grasp_pose")
    assert stored.shape == (4, 4)
    assert np.linalg.norm(stored[:3, 3] - pipe[:3, 3]) < 0.25  # vision noise + latency while moving


def test_survey_fails_when_waypoints_end_without_detection(make_ctx, tick):
    ctx = make_ctx({"grasp_pose": "pose"})
    ctx.devices.vehicle.arm()
    ctx.sim.inject("vision_lost")
    here = ctx.devices.vehicle.navigation().position
    wp = {"north_m": here[0] + 0.5, "east_m": here[1], "down_m": None, "altitude_m": None, "yaw_deg": None}
    until = PredicateEval("detected", {"min_confidence": 0.5, "max_age_s": 0.5, "store_as": None})
    leaf = KclAction(
        "Survey", ctx, "survey", targets={"waypoints": [wp], "tolerance_m": 0.3}, until=until, timeout_s=60
    )
    assert tick(leaf, ctx, max_s=60, step=drive_vehicle) == Status.FAILURE
    assert "never held" in leaf.feedback_message and ctx.motion_stops == 1


def test_tool_goal_follows_new_detections(make_ctx, tick):
    ctx = make_ctx({"grasp_pose": "pose"}, seed=3)
    ctx.devices.vehicle.arm()
    pipe = ctx.sim.pipe_grasp_pose()
    # put the vehicle where the camera sees the pipe
    survey = KclAction(
        "Approach",
        ctx,
        "survey",
        targets={
            "vehicle_goal": {
                "north_m": pipe[0, 3] - 1.8,
                "east_m": pipe[1, 3] - 0.2,
                "altitude_m": 2.0,
                "yaw_deg": 0.0,
            },
            "tolerance_m": 0.3,
        },
        timeout_s=60,
    )
    assert tick(survey, ctx, max_s=60, step=drive_vehicle) == Status.SUCCESS
    ctx.blackboard.set("grasp_pose", np.eye(4))
    leaf = KclAction(
        "Grasp",
        ctx,
        "grasp",
        targets={"tool_goal_from": "grasp_pose"},
        timeout_s=30,
        track_detection={"store_as": "grasp_pose", "min_confidence": 0.5, "max_age_s": 0.5},
    )
    t0 = ctx.now()
    tick(leaf, ctx, max_s=2.0)
    calls = ctx.controller.calls
    start = max(i for i, c in enumerate(calls) if c[0] == "set_action" and c[1] == "grasp")
    assert calls[start + 1] == ("clear_targets",)  # the previous attempt's goal is dropped
    tool_goals = [c[1]["tool_goal"] for c in calls[start:] if c[0] == "set_targets" and "tool_goal" in c[1]]
    assert not any(np.allclose(g, np.eye(4)) for g in tool_goals)  # never the stale blackboard value
    assert len(tool_goals) >= 3  # vision at ~10 Hz: new targets every detection
    assert np.linalg.norm(tool_goals[-1][:3, 3] - pipe[:3, 3]) < 0.25
    acquired = [e for e in ctx.events.events if e["kind"] == "target_acquired"]
    assert len(acquired) == 1 and acquired[0]["image_t"] >= t0


def test_a_retry_without_a_fresh_detection_never_gets_a_tool_goal(make_ctx, tick):
    # the camera sees nothing: the stale goal left by an earlier attempt is not used,
    # the reach waits and times out instead of converging on it
    ctx = make_ctx({"grasp_pose": "pose"}, seed=3)
    ctx.devices.vehicle.arm()
    ctx.sim.inject("vision_lost")
    ctx.blackboard.set("grasp_pose", ctx.sim.pipe_grasp_pose())
    leaf = KclAction(
        "Grasp",
        ctx,
        "grasp",
        targets={"tool_goal_from": "grasp_pose"},
        timeout_s=2.0,
        track_detection={"store_as": "grasp_pose", "min_confidence": 0.5, "max_age_s": 0.5},
    )
    assert tick(leaf, ctx, max_s=5.0) == Status.FAILURE
    assert "timed out" in leaf.feedback_message
    assert not [c for c in ctx.controller.calls if c[0] == "set_targets" and "tool_goal" in c[1]]
    assert "target_acquired" not in ctx.events.kinds()


def test_action_inside_a_tree_is_halted_by_a_sibling(make_ctx, tick):
    ctx = make_ctx()
    from behaviours.wait import Wait

    action = KclAction("Hold", ctx, "hold", timeout_s=100)
    root = py_trees.composites.Parallel(
        "race", policy=py_trees.common.ParallelPolicy.SuccessOnOne(), children=[action, Wait("w", ctx, 0.5)]
    )
    assert tick(root, ctx, max_s=2.0) == Status.SUCCESS
    assert action.status == Status.INVALID and ctx.motion_stops == 1


def test_unknown_action_at_run_time_fails_cleanly(make_ctx):
    ctx = make_ctx()
    leaf = KclAction("Dock", ctx, "dock", timeout_s=10)
    leaf.tick_once()
    assert leaf.status == Status.FAILURE and "no action `dock`" in leaf.feedback_message
    assert ctx.motion_stops == 1


def test_non_finite_navigation_at_start_fails_and_stops(make_ctx):
    ctx = make_ctx()
    ctx.sim.inject("ahrs_nan")
    ctx.advance(0.1)
    leaf = KclAction("Go", ctx, "survey", targets={"vehicle_goal": {"north_m": 1.0}}, timeout_s=10)
    leaf.tick_once()
    assert leaf.status == Status.FAILURE and "not finite" in leaf.feedback_message
    assert ctx.motion_stops == 1 and ctx.controller.stopped
    assert not any(c[0] == "set_targets" for c in ctx.controller.calls)  # no NaN goal was sent


def test_retried_action_waits_for_a_fresh_controller_step(make_ctx):
    """Same action again (a retry): the controller keeps its last errors; they
    must not count until it has stepped after the leaf started."""
    ctx = make_ctx()
    ctx.controller.action, ctx.controller.converged, ctx.controller.t = "grasp", True, 0.0
    ctx.advance(1.0)
    ctx.controller.set_action = lambda name, t: None  # same action: no change, as UvmsController does
    leaf = KclAction(
        "Reach", ctx, "grasp", until=PredicateEval("converged", {"max_error": 0.05, "for_s": None}), timeout_s=10
    )
    leaf.tick_once()
    assert leaf.status == Status.RUNNING  # errors from t=0.0 are older than the start at t=1.0
    ctx.controller.t = ctx.now() + 0.01
    leaf.tick_once()
    assert leaf.status == Status.SUCCESS


def test_new_targets_restart_convergence(make_ctx):
    ctx = make_ctx({"grasp_pose": "pose"})
    ctx.blackboard.set("grasp_pose", np.eye(4))
    leaf = KclAction("Reach", ctx, "grasp", targets={"tool_goal_from": "grasp_pose"}, timeout_s=10)
    leaf.tick_once()
    ctx.advance(0.5)
    ctx.controller.converged, ctx.controller.t = True, ctx.now() - 0.1
    moved = np.eye(4)
    moved[0, 3] = 0.2
    ctx.blackboard.set("grasp_pose", moved)  # a new detection moved the target
    leaf.tick_once()
    assert leaf.status == Status.RUNNING
    ctx.controller.t = ctx.now() + 0.01
    leaf.tick_once()
    assert leaf.status == Status.SUCCESS


def test_converged_for_a_while(make_ctx, tick):
    ctx = make_ctx()
    leaf = KclAction(
        "Reach", ctx, "grasp", until=PredicateEval("converged", {"max_error": None, "for_s": 1.0}), timeout_s=10
    )
    leaf.tick_once()
    ctx.controller.converged = True
    assert tick(leaf, ctx, max_s=5.0) == Status.SUCCESS
    assert 1.0 <= ctx.now() <= 1.2


def test_small_target_updates_do_not_restart_convergence(make_ctx):
    ctx = make_ctx({"grasp_pose": "pose"})
    ctx.blackboard.set("grasp_pose", np.eye(4))
    leaf = KclAction("Reach", ctx, "grasp", targets={"tool_goal_from": "grasp_pose"}, timeout_s=10)
    leaf.tick_once()
    ctx.advance(0.5)
    ctx.controller.converged, ctx.controller.t = True, ctx.now() - 0.1
    noisy = np.eye(4)
    noisy[0, 3] = 0.01  # vision noise: 1 cm
    ctx.blackboard.set("grasp_pose", noisy)
    leaf.tick_once()
    assert leaf.status == Status.SUCCESS
    assert np.allclose(ctx.controller.targets["tool_goal"], noisy)  # still sent
