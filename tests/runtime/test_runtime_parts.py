"""The supervisor's pure parts: lifecycle, schedule, safety checks, progress line."""

from __future__ import annotations

import io
import math
from types import SimpleNamespace

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from transitions import MachineError

from hal.interfaces import Health, HealthState, JointState, NavigationState
from mission.runtime.lifecycle import Lifecycle
from mission.runtime.operator import CommandQueue, ScriptedOperator
from mission.runtime.progress import ProgressDisplay
from mission.runtime.result import SupervisorOptions
from mission.runtime.safety import VELOCITY_STREAM, PolledDevices, SafetyMonitor, geofence_margin
from mission.runtime.schedule import make_schedule
from mission.runtime.supervisor import LOG_OFFSETS

GEOFENCE = SimpleNamespace(north_m=(-10.0, 10.0), east_m=(-5.0, 5.0), down_m=(0.0, 8.0))
SAFETY = SimpleNamespace(
    max_depth_m=6.0,
    min_altitude_m=0.5,
    max_duration_s=100.0,
    geofence=GEOFENCE,
    watchdog_s={"navigation": 0.5, "joints": 0.2},
)


def nav(t=1.0, pos=(0.0, 0.0, 3.0), vel=(0.1, 0, 0, 0, 0, 0), vel_t=1.0, altitude=2.0):
    return NavigationState(
        t=t,
        position=np.array(pos, float),
        attitude=np.zeros(3),
        body_velocity=None if vel is None else np.array(vel, float),
        velocity_t=vel_t if vel is not None else None,
        depth=pos[2],
        altitude=altitude,
    )


def joints(t=1.0, q=(0.0, 0.1), fault=None):
    q = np.array(q, float)
    return JointState(t=t, position=q, velocity=np.zeros_like(q), current=np.zeros_like(q), fault=fault)


def check(monitor, now=1.0, n=None, js=None, health=None):
    n = n if n is not None else nav(t=now, vel_t=now)
    js = js if js is not None else joints(t=now)
    return monitor.check(now, now, n, js, PolledDevices(bad=health or {}))


def test_lifecycle_paths_and_rejects_invalid_triggers():
    seen = []
    lc = Lifecycle(lambda *a: seen.append(a))
    for trig in ("start", "preflight_ok", "pause", "resume", "abort", "abort_done"):
        lc.go(trig, f"because {trig}")
    assert lc.state == "aborted" and lc.finished
    assert [s[1] for s in seen] == ["preflight", "running", "paused", "running", "aborting", "aborted"]
    assert seen[2][3] == "because pause"
    with pytest.raises(MachineError):
        lc.go("resume")
    lc2 = Lifecycle()
    lc2.go("start")
    assert not lc2.can("pause")
    lc2.go("preflight_failed", "no nav")
    assert lc2.state == "failed"


@settings(max_examples=60, deadline=None)
@given(base=st.sampled_from([50.0, 100.0, 200.0, 250.0]), tree=st.floats(1.0, 50.0), veh=st.floats(5.0, 40.0))
def test_schedule_rates_close_to_requested(base, tree, veh):
    sch = make_schedule(base, {"tree": tree, "vehicle": veh})
    for name, hz in (("tree", tree), ("vehicle", veh)):
        eff = sch.rate(name)
        assert eff <= base + 1e-9
        div = sch.jobs[name].divider
        assert div == max(1, round(base / hz))  # nearest whole number of base steps per period
        runs = sum(sch.due(name, k) for k in range(div * 7))
        assert runs == 7


def test_kcl_and_device_logs_run_on_the_vehicle_step():
    """/kcl and the device log run on the step of the tree tick and the vehicle KCL:
    ``maris log summary`` dates action switches from /kcl, ``maris calibrate`` reads
    the vehicle commands at the step they were computed."""
    o = SupervisorOptions()
    rates = {"tree": 10.0, "vehicle": 10.0, "kcl_log": o.kcl_log_hz, "device_log": o.device_log_hz}
    sch = make_schedule(100.0, rates, LOG_OFFSETS)
    for step in range(100):
        if sch.due("vehicle", step):
            assert sch.due("tree", step) and sch.due("kcl_log", step) and sch.due("device_log", step)


def test_schedule_rejects_bad_rates():
    with pytest.raises(ValueError):
        make_schedule(100.0, {"tree": 0.0})


def test_nominal_snapshot_has_no_breach_and_margins():
    m = SafetyMonitor(SAFETY)
    breaches, margins = check(m)
    assert breaches == []
    assert margins["depth_m"] == pytest.approx(3.0)
    assert margins["altitude_m"] == pytest.approx(1.5)
    assert margins["geofence_m"] == pytest.approx(3.0)  # 3 m from the surface bound
    assert margins["duration_s"] == pytest.approx(99.0)


def test_dvl_dropout_trips_velocity_watchdog_only_after_limit():
    m = SafetyMonitor(SAFETY, velocity_watchdog_s=1.0)
    assert check(m, now=1.0)[0] == []  # velocity seen once
    assert check(m, now=1.8, n=nav(t=1.8, vel_t=1.0))[0] == []  # 0.8 s: one lost ping is fine
    breaches, _ = check(m, now=2.2, n=nav(t=2.2, vel_t=1.0))
    assert [(b.kind, b.source) for b in breaches] == [("watchdog", VELOCITY_STREAM)]


def test_vehicle_without_dvl_is_not_watched_for_velocity():
    m = SafetyMonitor(SAFETY)
    assert check(m, now=50.0, n=nav(t=50.0, vel=None))[0] == []


def test_stale_pose_and_joints_trip_their_watchdogs():
    m = SafetyMonitor(SAFETY)
    breaches, _ = check(m, now=3.0, n=nav(t=2.0, vel_t=3.0), js=joints(t=2.9))
    assert {b.source for b in breaches} == {"navigation"}
    breaches, _ = check(m, now=3.0, n=nav(t=3.0, vel_t=3.0), js=joints(t=2.7))
    assert {b.source for b in breaches} == {"joints"}


@pytest.mark.parametrize(
    "n, source",
    [
        (nav(pos=(0, 0, 6.5)), "depth_m"),
        (nav(altitude=0.3), "altitude_m"),
        (nav(pos=(12.0, 0, 3.0)), "geofence_m"),
    ],
)
def test_envelope_breaches(n, source):
    breaches, margins = check(SafetyMonitor(SAFETY), n=n)
    assert ("envelope", source) in {(b.kind, b.source) for b in breaches}
    assert margins[source] < 0


def test_duration_limit():
    breaches, _ = check(SafetyMonitor(SAFETY), now=101.0)
    assert ("envelope", "duration_s") in {(b.kind, b.source) for b in breaches}


def test_non_finite_and_drive_faults():
    m = SafetyMonitor(SAFETY)
    breaches, _ = check(
        m,
        n=nav(vel=(math.nan, 0, 0, 0, 0, 0)),
        js=joints(fault="joint 2: overcurrent"),
        health={"arm": Health(HealthState.FAULT, 1.0, "heartbeat lost")},
    )
    kinds = {(b.kind, b.source) for b in breaches}
    assert {("non_finite", "navigation"), ("drive_fault", "arm")} <= kinds


@settings(max_examples=80, deadline=None)
@given(p=st.tuples(st.floats(-20, 20), st.floats(-20, 20), st.floats(-5, 15)))
def test_geofence_margin_sign_matches_contains(p):
    margin = geofence_margin(GEOFENCE, p)
    inside = -10 <= p[0] <= 10 and -5 <= p[1] <= 5 and 0 <= p[2] <= 8
    assert (margin >= 0) == inside


def test_scripted_operator_in_time_order():
    q = CommandQueue()
    op = ScriptedOperator(q, [(5.0, "resume"), (2.0, "pause")])
    op.poll(1.0)
    assert q.drain() == []
    op.poll(6.0)
    assert [c for c, _ in q.drain()] == ["pause", "resume"]


def test_progress_plain_lines_every_period():
    out = io.StringIO()
    p = ProgressDisplay(out, tty=False, plain_period_s=10.0)
    for k in range(250):
        p.update(k * 0.1, "running", "survey", "Survey")
    lines = out.getvalue().splitlines()
    assert len(lines) == 3 and "action=survey" in lines[0] and lines[1].startswith("t=   10.0")


def test_closest_approach_skips_unknown_margins() -> None:
    """A NaN margin (no position fix yet) is not a closest approach: the later
    finite ones are kept (a NaN first would have hidden them all)."""
    m = SafetyMonitor(SAFETY)
    m.record({"depth_m": math.nan}, 0.0)
    m.record({"depth_m": 2.0}, 1.0)
    m.record({"depth_m": math.nan}, 2.0)
    m.record({"depth_m": 1.5}, 3.0)
    assert m.closest["depth_m"] == 1.5 and m.closest_t["depth_m"] == 3.0
    m.record({"altitude_m": math.nan}, 0.0)
    assert "altitude_m" not in m.closest
