"""SafetyMonitor.check against a plain transcription of the safety rules
(docs/faults.md): same breaches, margins and closest approaches, step after step,
for readings with NaN, infinities, overflowing sums, stale and missing streams."""

from __future__ import annotations

import math
from dataclasses import replace
from types import SimpleNamespace

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from hal.interfaces import Health, HealthState, JointState, NavigationState
from mission.runtime.safety import (
    ENVELOPE_TEXT,
    VELOCITY_STREAM,
    Breach,
    PolledDevices,
    SafetyMonitor,
    classify_health,
    geofence_margin,
)


class PlainMonitor:
    """The rules one by one, numpy on every value, no shortcuts."""

    def __init__(self, safety: SimpleNamespace, velocity_watchdog_s: float) -> None:
        self.safety = safety
        self.watchdog_s = dict(safety.watchdog_s)
        self.watchdog_s[VELOCITY_STREAM] = max(velocity_watchdog_s, self.watchdog_s["navigation"])
        self.velocity_seen = False
        self.closest: dict[str, float] = {}
        self.closest_t: dict[str, float] = {}

    def check(self, now, elapsed, nav, js, polled):
        s = self.safety
        margins = {"duration_s": s.max_duration_s - elapsed, "depth_m": s.max_depth_m - nav.depth}
        if nav.altitude is not None:
            margins["altitude_m"] = nav.altitude - s.min_altitude_m
        if s.geofence is not None:
            margins["geofence_m"] = geofence_margin(s.geofence, nav.position)
        for k, v in margins.items():
            if not math.isnan(v) and (k not in self.closest or v < self.closest[k]):
                self.closest[k], self.closest_t[k] = v, elapsed
        out = []
        for name in ("position", "attitude", "body_velocity", "depth"):
            value = getattr(nav, name)
            if value is not None and not np.all(np.isfinite(value)):
                out.append(Breach("non_finite", "navigation", f"non-finite {name}: {value}"))
        for name in ("position", "velocity"):
            if not np.all(np.isfinite(getattr(js, name))):
                out.append(Breach("non_finite", "joints", f"non-finite joint {name}: {getattr(js, name)}"))
        device: dict = {}
        for role, h in polled.bad.items():
            for b in classify_health(role, h):
                device.setdefault((b.kind, b.source), b)
        if js.fault:
            device.setdefault(("drive_fault", "arm"), Breach("drive_fault", "arm", f"joint fault: {js.fault}"))
        if polled.gripper_fault:
            b = Breach("gripper_fault", "gripper", f"gripper fault: {polled.gripper_fault}")
            device.setdefault(("gripper_fault", "gripper"), b)
        out += device.values()
        times = {**polled.stream_times, "joints": js.t, "navigation": nav.t}
        if nav.velocity_t is not None and nav.body_velocity is not None:
            self.velocity_seen = True
        if self.velocity_seen:
            times[VELOCITY_STREAM] = nav.velocity_t if nav.body_velocity is not None else None
        for stream, limit in self.watchdog_s.items():
            if stream not in times:
                continue
            if times[stream] is None:
                out.append(Breach("watchdog", stream, f"no {stream} reading (limit {limit:.3g} s)"))
                continue
            age = now - times[stream]
            if not math.isfinite(age) or age > limit:
                out.append(Breach("watchdog", stream, f"{stream} reading is {age:.3f} s old (limit {limit:.3g} s)"))
        for k, v in margins.items():
            if math.isfinite(v) and v < 0:
                out.append(Breach("envelope", k, f"{ENVELOPE_TEXT[k]} (margin {v:.3f})"))
        return out, margins


GEOFENCE = SimpleNamespace(north_m=(-10.0, 10.0), east_m=(-5.0, 5.0), down_m=(0.0, 8.0))
WATCHED = {"navigation": 0.5, "joints": 0.2, "gripper": 0.5}

value = st.floats(-20.0, 20.0)
vec3 = st.lists(value, min_size=3, max_size=3)
age = st.floats(0.0, 0.6)
SPECIAL = [math.nan, math.inf, -math.inf, 1e308, 3.0]


@st.composite
def step(draw: st.DrawFn) -> tuple:
    now = draw(st.floats(0.0, 150.0))
    bv = draw(st.one_of(st.none(), st.lists(value, min_size=6, max_size=6)))
    nav = NavigationState(
        t=now - draw(age),
        position=np.array(draw(vec3)),
        attitude=np.array(draw(vec3)),
        body_velocity=None if bv is None else np.array(bv),
        velocity_t=None if bv is None else now - draw(age),
        depth=draw(value),
        altitude=draw(st.one_of(st.none(), value)),
    )
    q = np.array(draw(st.lists(value, min_size=2, max_size=2)))
    js = JointState(
        t=now - draw(age),
        position=q,
        velocity=np.array(draw(st.lists(value, min_size=2, max_size=2))),
        current=np.zeros(2),
        fault=draw(st.sampled_from([None, "", "j1 fault"])),
    )
    poison = draw(
        st.sampled_from(
            [
                None,
                "position",
                "attitude",
                "body_velocity",
                "q",
                "qdot",
                "depth",
                "altitude",
                "nav_t",
                "js_t",
                "velocity_t",
            ]
        )
    )
    special = draw(st.sampled_from(SPECIAL))
    if poison in ("position", "attitude") or (poison == "body_velocity" and nav.body_velocity is not None):
        getattr(nav, poison)[draw(st.integers(0, 2))] = special
    elif poison in ("q", "qdot"):
        (js.position if poison == "q" else js.velocity)[draw(st.integers(0, 1))] = special
    elif poison == "depth":
        nav = replace(nav, depth=special)
    elif poison == "altitude":
        nav = replace(nav, altitude=special)
    elif poison == "nav_t":
        nav = replace(nav, t=now - special)
    elif poison == "js_t":
        js = replace(js, t=now - special)
    elif poison == "velocity_t" and nav.velocity_t is not None:
        nav = replace(nav, velocity_t=now - special)
    bad = draw(st.sampled_from([{}, {}, {"arm": Health(HealthState.FAULT, "drive")}]))
    others = draw(st.sampled_from([{}, {}, {"gripper": None}, {"gripper": now - 0.1}, {"gripper": now - 3.0}]))
    return now, nav, js, PolledDevices(bad, others, draw(st.sampled_from([None, None, "stuck"])))


@pytest.mark.slow
@settings(max_examples=300, deadline=None)
@given(st.lists(step(), min_size=1, max_size=4), st.booleans())
def test_check_follows_the_rules(steps: list, fenced: bool) -> None:
    safety = SimpleNamespace(
        max_depth_m=6.0,
        min_altitude_m=0.5,
        max_duration_s=100.0,
        geofence=GEOFENCE if fenced else None,
        watchdog_s=WATCHED,
    )
    monitor, plain = SafetyMonitor(safety, 1.0), PlainMonitor(safety, 1.0)
    for now, nav, js, polled in steps:
        breaches, margins = monitor.check(now, now, nav, js, polled)
        want_breaches, want_margins = plain.check(now, now, nav, js, polled)
        assert [str(b) for b in breaches] == [str(b) for b in want_breaches]
        assert [b.ending for b in breaches] == [b.ending for b in want_breaches]
        assert margins.keys() == want_margins.keys()
        assert all(a == b or (a != a and b != b) for a, b in zip(margins.values(), want_margins.values()))
        assert (monitor.closest, monitor.closest_t) == (plain.closest, plain.closest_t)


def test_joint_margin_is_the_nearest_limit_and_recorded() -> None:
    safety = SimpleNamespace(max_depth_m=6.0, min_altitude_m=0.5, max_duration_s=100.0, geofence=None, watchdog_s={})
    monitor = SafetyMonitor(safety, 1.0, (np.array([-1.0, -2.0]), np.array([1.0, 2.0])))
    assert monitor.joint_margin(np.array([0.5, 1.9]), 3.0) == pytest.approx(0.1)
    assert monitor.joint_margin(np.array([1.5, 0.0]), 4.0) == pytest.approx(-0.5)
    assert math.isnan(monitor.joint_margin(np.array([math.nan, 0.0]), 5.0))
    assert monitor.closest["joint_limits_rad"] == pytest.approx(-0.5) and monitor.closest_t["joint_limits_rad"] == 4.0
    assert SafetyMonitor(safety).joint_margin(np.zeros(2), 1.0) is None
