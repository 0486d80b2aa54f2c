"""The operator on a gamepad, on the simulator: recorded Xbox 360 pad sessions (kernel
event streams, played through the real driver's decoding) drive the tool and the vehicle;
pushed on purpose against the geofence, the altitude floor, the bottom and the joint
limits, the system never crosses them, and the log says which task held the operator
back; the pad unplugged mid-jog stops the motion within the dead-man time."""

from __future__ import annotations

import numpy as np
import pytest

from kcl.model import UvmsModel

pytestmark = [pytest.mark.slow]

TICK = 0.1  # s, the tree period


def _margins(run) -> dict[str, float]:
    """The closest approach to each safety limit over the run (m, rad; positive inside)."""
    out: dict[str, float] = {}
    for m in run.log.messages("/safety/margins"):
        for k, v in m["margins"].items():
            out[k] = min(out.get(k, np.inf), v)
    return out


def _limited_by(run) -> set[str]:
    return {b for e in run.events("teleop_limited") for b in e["fields"]["by"]}


def _no_breach(run) -> None:
    assert not run.events("envelope"), run.events("envelope")
    assert not [e for e in run.events("sim") if "below the floor" in e["message"]]


def test_each_velocity_mode_follows_the_pad_and_the_pad_hands_back(kit):
    """Vehicle jog: the left stick forward moves the vehicle forward (north); A switches to
    the tool jog; the right stick down moves the tool down (the vehicle's z axis); start
    hands back. The log says who had control when, in which mode, with which input."""
    H = kit.Hold
    mission = kit.mission("m", modes="[vehicle_velocity, tool_velocity]", inputs="[gamepad]", timeout_s=60)
    run = kit.pad(
        mission,
        [
            H(1.0, {"ABS_Y": -1.0}, ["BTN_TL"]),
            H(6.0),
            H(7.0, {}, ["BTN_SOUTH"]),
            H(7.3),
            H(8.0, {"ABS_RY": 0.5}, ["BTN_TL"]),
            H(12.0),
            H(13.0, {}, ["BTN_START"]),
            H(13.3),
        ],
        end_s=15.0,
    )
    assert run.result.outcome == "succeeded", run.result.failure_cause
    t0 = run.teleop_start()
    nav = {round(m["t"], 2): m["position"] for m in run.log.messages("/vehicle/navigation")}
    assert nav[round(t0 + 6.0, 2)][0] - nav[round(t0 + 1.0, 2)][0] > 0.6
    modes = [(e["fields"]["previous"], e["fields"]["mode"]) for e in run.events("teleop_mode")]
    assert modes == [("vehicle_velocity", "tool_velocity")]
    truth = {round(m["t"], 1): m["tool"]["position"] for m in run.log.messages("/ground_truth")}
    assert truth[round(t0 + 12.0, 1)][2] - truth[round(t0 + 8.0, 1)][2] > 0.15  # the tool went down
    control = run.events("control")
    assert [e["fields"]["who"] for e in control] == ["operator", "autonomy"]
    assert control[1]["t"] == pytest.approx(t0 + 13.0, abs=TICK + 1e-9)  # at the first tick after the press
    teleop = run.log.messages("/operator/teleop")
    assert {m["input"] for m in teleop if m["control"] == "operator"} == {"gamepad", None}
    assert teleop[-1]["control"] == "autonomy"
    actions = [a for _, a in run.result.actions]
    assert actions[-3:] == ["jog_vehicle", "jog_tool_vehicle", "hold"]


def test_driving_into_the_geofence_stops_inside_it_and_says_so(kit):
    """The mission's fence ends 2.5 m ahead of the start (north 11 m); the operator holds the
    stick forward for 30 s: the vehicle stops inside the fence, with the KCL's margin, and the
    geofence task is named."""
    mission = kit.mission("m", north=11.0, modes="[vehicle_velocity]", inputs="[gamepad]", timeout_s=35)
    run = kit.pad(mission, [kit.Hold(0.5, {"ABS_Y": -1.0}, ["BTN_TL"]), kit.Hold(30.5)], end_s=32.0)
    _no_breach(run)
    assert 0.3 < _margins(run)["geofence_m"]  # the fence's task keeps 0.5 m (a little less while it brakes)
    north = max(m["position"][0] for m in run.log.messages("/vehicle/navigation"))
    assert north > 10.0  # it did go most of the way
    assert "geofence" in _limited_by(run)


def test_driving_down_onto_the_bottom_stops_above_the_altitude_floor_and_says_so(kit):
    """The operator holds the vehicle's heave down for 25 s: it stops where its DVL keeps
    bottom lock (operator_altitude), above the mission's altitude floor, the arm clear of
    the bottom; the task that stopped it is named."""
    mission = kit.mission("m", modes="[vehicle_velocity]", inputs="[gamepad]", timeout_s=30)
    run = kit.pad(mission, [kit.Hold(0.5, {"ABS_RY": 1.0}, ["BTN_TL"]), kit.Hold(25.5)], end_s=27.0)
    _no_breach(run)
    assert run.events("teleop_limited")
    assert _margins(run)["altitude_m"] > 0.4
    assert not run.events("watchdog")  # the DVL kept its lock
    assert _limited_by(run) & {"operator_altitude", "tool_clearance", "altitude"}


def test_jogging_the_tool_down_stops_it_above_the_bottom_and_says_so(kit):
    """Tool jog in world axes, straight down for 30 s: the tool stops above the bottom
    (tool_clearance), the vehicle above its floor; tool_clearance is named."""
    mission = kit.mission("m", modes="[tool_velocity]", frame="world", inputs="[gamepad]", timeout_s=35)
    run = kit.pad(mission, [kit.Hold(0.5, {"ABS_RY": 1.0}, ["BTN_TL"]), kit.Hold(30.5)], end_s=32.0)
    _no_breach(run)
    floor = 4.0  # pool_clear: a flat bottom 4 m deep
    deepest = max(m["tool"]["position"][2] for m in run.log.messages("/ground_truth"))
    assert floor - deepest > 0.1  # the tool_clearance task keeps 0.15 m at the tool frame
    assert floor - deepest < 0.4  # it did go down to the band
    assert "tool_clearance" in _limited_by(run)


def test_rolling_the_tool_against_the_joint_limits_never_crosses_them_and_says_so(kit):
    """The operator rolls the tool (d-pad) for 80 s, far beyond the arm's joint ranges: no
    joint ever passes its limit, and joint_limits is named as holding the roll back."""
    model = UvmsModel.load()
    mission = kit.mission("m", modes="[tool_velocity]", inputs="[gamepad]", timeout_s=85)
    run = kit.pad(mission, [kit.Hold(0.5, {"ABS_HAT0X": 1.0}, ["BTN_TL"]), kit.Hold(80.5)], end_s=82.0)
    _no_breach(run)
    q = np.array([m["position"] for m in run.log.messages("/arm/state")])
    assert np.all(q >= model.joint_lower) and np.all(q <= model.joint_upper)
    assert _margins(run)["joint_limits_rad"] > 0.0
    assert "joint_limits" in _limited_by(run)


def test_the_pad_unplugged_mid_jog_stops_the_motion_within_the_dead_man_time(kit):
    """The pad is pulled out 5 s into a forward jog (its recording goes on: the hand on
    the stick): within the dead-man time (plus one tree tick) the command is zero; the
    input's loss is logged as a warning, not a fault that ends the run."""
    mission = kit.mission("m", fold=False, modes="[vehicle_velocity]", inputs="[gamepad]", deadman_s=0.5, timeout_s=15)
    unplug = 5.0  # simulated time; the teleop starts at the first tick
    run = kit.pad(
        mission, [kit.Hold(0.0, {"ABS_Y": -1.0}, ["BTN_TL"])], end_s=15.0, **{"operator.gamepad_unplug_s": unplug}
    )
    t0 = run.teleop_start()
    assert t0 < 0.5 and run.events("teleop_input")[0]["fields"]["role"] == "gamepad"
    stops = [e for e in run.events("teleop_input") if e["fields"]["role"] is None]
    assert stops and unplug < stops[0]["t"] <= unplug + 0.5 + TICK + 1e-9
    assert "no fresh command" in stops[0]["message"]
    cmds = [m["body_velocity"][0] for m in run.log.messages("/vehicle/command") if m["t"] > stops[0]["t"] + 1.0]
    assert cmds and max(abs(c) for c in cmds) < 0.02
    lost = run.events("operator_input")
    assert lost and lost[0]["level"] == "warning" and "unplugged" in lost[0]["message"]
