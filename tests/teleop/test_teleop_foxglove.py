"""The operator on the Foxglove live view, on the simulator: a real Foxglove-protocol
WebSocket client publishes the Teleop panel's Twist, the 3D panel's clicked poses and
points (JSON ``geometry_msgs``, frames ``map`` and ``vehicle_level``) and presses, in lock
step with the run (tests/teleop/conftest.py). Each mode moves the system as asked; a
dropped connection stops the motion within the dead-man time; a goal 2 s late still
converges, a velocity 2 s late is dropped; the handback service gives control back."""

from __future__ import annotations

import math

import numpy as np
import pytest

pytestmark = [pytest.mark.slow]

TICK = 0.1  # s, the tree period (the teleop's reaction time)


def _every(kit, t0: float, t1: float, action, period: float = 0.1) -> list:
    """``action`` every ``period`` s from ``t0`` to ``t1`` (the Teleop panel repeats its twist at its rate)."""
    n = int(round((t1 - t0) / period))
    return [kit.Step(t0 + i * period, action) for i in range(n + 1)]


def _nav_at(run, t: float) -> dict:
    return min(run.log.messages("/vehicle/navigation"), key=lambda m: abs(m["t"] - t))


def test_the_teleop_panels_twist_drives_the_vehicle_and_a_dropped_connection_stops_it(kit):
    """vehicle_velocity: the Teleop panel's forward button (linear x) at 10 Hz for 6 s moves
    the vehicle forward; then the WebSocket drops mid-jog: within the dead-man time (plus one
    tree tick) the command is zero and the vehicle's commanded velocity with it."""
    mission = kit.mission("m", modes="[vehicle_velocity]", inputs="[foxglove]", deadman_s=0.5, timeout_s=20)
    steps = _every(kit, 0.5, 6.5, lambda c, now: c.twist([0.2, 0, 0, 0, 0, 0]))
    steps.append(kit.Step(6.55, lambda c, now: c.close()))
    run = kit.foxglove(mission, steps)
    t0 = run.teleop_start()
    drop = t0 + 6.6  # the tree step at which the close was sent
    nav0, nav1 = _nav_at(run, t0 + 0.5), _nav_at(run, drop)
    assert nav1["position"][0] - nav0["position"][0] > 0.6  # forward (north: heading 0) under the twist
    stops = [e for e in run.events("teleop_input") if e["t"] > t0 + 1 and e["fields"]["role"] is None]
    assert stops and stops[0]["t"] <= drop + 0.5 + TICK + 1e-9
    later = [m for m in run.log.messages("/vehicle/command") if m["t"] > stops[0]["t"] + 1.0]
    assert later and max(abs(m["body_velocity"][0]) for m in later) < 0.02
    teleop = [m for m in run.log.messages("/operator/teleop") if m["t"] >= stops[0]["t"]]
    assert all(m["command"] == [0.0] * 6 for m in teleop if m["control"] == "operator")
    assert any("disconnected" in e["message"] for e in run.events("live"))


def test_a_clicked_pose_sends_the_vehicle_there_and_a_clicked_point_the_tool(kit):
    """vehicle_goal: a pose clicked in the 3D view's ``map`` frame (ENU, on its ground
    plane: x east, y north) at north 10.5 m, east 7.0 m, heading east: the vehicle goes
    there at its depth and turns east. Then (``{"mode": "tool_goal"}``) a point clicked in
    ``vehicle_level`` 0.4 m north of the vehicle: the tool goes there, its depth and
    orientation kept. The handback service gives control back."""
    mission = kit.mission("m", modes="[vehicle_goal, tool_goal]", inputs="[foxglove]", timeout_s=70)
    steps = [
        kit.Step(0.5, lambda c, now: c.pose("map", (7.0, 10.5, 0.0), yaw=0.0, stamp=now)),  # yaw 0 about up: east
        kit.Step(30.0, lambda c, now: c.command({"mode": "tool_goal"})),
        kit.Step(30.5, lambda c, now: c.point("vehicle_level", (0.0, 0.4, 0.0), stamp=now)),
        kit.Step(60.0, lambda c, now: c.call_service("/operator/handback")),
    ]
    run = kit.foxglove(mission, steps)
    assert run.result.outcome == "succeeded", run.result.failure_cause
    t0 = run.teleop_start()
    goals = run.events("teleop_goal")
    gx, gy, gz, gyaw = next(g for g in goals if g["fields"]["mode"] == "vehicle_goal")["fields"]["goal"]
    click = _nav_at(run, t0 + 0.6)
    assert (gx, gy) == pytest.approx((10.5, 7.0), abs=1e-9)
    assert gz == pytest.approx(click["position"][2], abs=0.02)  # its depth kept
    assert gyaw == pytest.approx(math.pi / 2, abs=1e-9)  # east
    nav = _nav_at(run, t0 + 29.5)
    assert math.dist(nav["position"][:2], (gx, gy)) < 0.3
    assert abs(math.remainder(nav["attitude"][2] - math.pi / 2, 2 * math.pi)) < 0.1
    tgoal = next(g for g in goals if g["fields"]["mode"] == "tool_goal")
    T = np.array(tgoal["fields"]["goal"])
    tool_click = _tool_at(run, t0 + 30.6)
    assert T[:2, 3] == pytest.approx(
        [_nav_at(run, t0 + 30.6)["position"][0] + 0.4, _nav_at(run, t0 + 30.6)["position"][1]], abs=0.02
    )
    assert T[2, 3] == pytest.approx(tool_click[2], abs=0.02)  # the tool's depth kept
    kcl = min(run.log.messages("/kcl"), key=lambda m: abs(m["t"] - (t0 + 59.5)))
    assert kcl["action"] == "reach"
    assert np.linalg.norm(kcl["tasks"]["tool_position"]["error"]) < 0.02  # reached, as navigation sees it
    assert np.linalg.norm(_tool_at(run, t0 + 59.5) - T[:3, 3]) < 0.15  # truth: within the navigation's drift
    control = run.events("control")
    assert control[-1]["fields"]["who"] == "autonomy" and "handback service" in control[-1]["message"]


def _tool_at(run, t: float) -> np.ndarray:
    truth = min(run.log.messages("/ground_truth"), key=lambda m: abs(m["t"] - t))
    return np.array(truth["tool"]["position"])


def test_a_goal_two_seconds_late_still_converges_and_a_late_velocity_is_dropped(kit):
    """High latency: every message reaches the run 2 s after the operator gave it (its
    stamp). A TwistStamped 2 s old is dropped (older than the 0.5 s dead-man) and the
    vehicle does not move for it; a goal 2 s old (limit 10 s) is taken and reached."""
    mission = kit.mission("m", modes="[vehicle_velocity, vehicle_goal]", inputs="[foxglove]", timeout_s=60)
    late = 2.0
    steps = _every(kit, 1.0, 4.0, lambda c, now: c.twist([0.3, 0, 0, 0, 0, 0], stamp=now - late))
    steps.append(kit.Step(5.0, lambda c, now: c.command({"mode": "vehicle_goal"})))
    steps.append(kit.Step(6.0 + late, lambda c, now: c.point("world", (11.0, 7.0, 2.0), stamp=now - late)))
    steps.append(kit.Step(50.0, lambda c, now: c.command({"button": "handback"})))
    run = kit.foxglove(mission, steps)
    assert run.result.outcome == "succeeded", run.result.failure_cause
    t0 = run.teleop_start()
    dropped = run.events("teleop_dropped")
    assert dropped and dropped[0]["fields"]["age_s"] == pytest.approx(late, abs=1e-6)
    a, b = _nav_at(run, t0 + 1.0), _nav_at(run, t0 + 5.0)
    assert math.dist(a["position"], b["position"]) < 0.1  # the late twist moved nothing
    goal = run.events("teleop_goal")[0]
    assert goal["fields"]["age_s"] == pytest.approx(late, abs=1e-6)
    end = _nav_at(run, t0 + 49.5)
    assert math.dist(end["position"], (11.0, 7.0, 2.0)) < 0.3


def test_pointing_at_the_pipe_turns_the_camera_to_it_and_seeds_the_detector(kit):
    """point_at: a point clicked on the pipe (in ``map``, on the ground plane) is placed on
    the bottom below it; the camera turns to it until the vision sees the pipe, which hands
    control back (``until: detected``); the detector was told where to search."""
    mission = kit.mission(
        "m",
        modes="[point_at]",
        inputs="[foxglove]",
        timeout_s=60,
        handback="{until: {detected: {min_confidence: 0.5, max_age_s: 1.0}}}",
    )
    pipe = (6.0, 8.5)  # north, east: beside and behind the start (8.5, 6.0), out of the camera's view
    steps = [kit.Step(0.5, lambda c, now: c.point("map", (pipe[1], pipe[0], 0.0), stamp=now))]
    run = kit.foxglove(mission, steps, **{"pipe.x_m": pipe[0], "pipe.y_m": pipe[1]})
    assert run.result.outcome == "succeeded", run.result.failure_cause
    seed = run.events("teleop_seed")[0]
    assert "world point" in seed["message"] and seed["fields"]["used"] is False
    goal = run.events("teleop_goal")[0]["fields"]["goal"]
    assert goal[:2] == pytest.approx(list(pipe), abs=1e-9) and goal[2] > 3.5  # on the bottom (pool 4 m deep)
    control = run.events("control")[-1]
    assert control["fields"]["who"] == "autonomy" and "detected" in control["message"]
