"""The supervisor's per-step safety fast path (:meth:`SafetyMonitor.quick_margins`)
decides exactly as the full check: same breaches, margins and closest approaches."""

from __future__ import annotations

import math
from dataclasses import replace
from types import SimpleNamespace

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from hal.interfaces import Health, HealthState, JointState, NavigationState
from mission.runtime.safety import SafetyMonitor, Snapshot

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
    return now, nav, js, (bad, others, draw(st.sampled_from([None, None, "stuck"])))


QUICK: list[bool] = []


@pytest.mark.slow
@settings(max_examples=300, deadline=None)
@given(st.lists(step(), min_size=1, max_size=4), st.booleans())
def test_fast_path_agrees_with_full_check(steps: list, fenced: bool) -> None:
    safety = SimpleNamespace(
        max_depth_m=6.0,
        min_altitude_m=0.5,
        max_duration_s=100.0,
        geofence=GEOFENCE if fenced else None,
        watchdog_s=WATCHED,
    )
    fast, full = SafetyMonitor(safety, 1.0), SafetyMonitor(safety, 1.0)
    for now, nav, js, polled in steps:
        bad, others, gripper_fault = polled

        def snapshot(monitor: SafetyMonitor) -> Snapshot:
            return Snapshot(
                now=now,
                elapsed=now,
                nav=nav,
                joints=js,
                health=bad,
                gripper_fault=gripper_fault,
                stream_times=monitor.stream_times(nav, {**others, "joints": js.t}),
            )

        margins = fast.quick_margins(now, now, nav, js, polled)
        QUICK.append(margins is not None)
        breaches = []
        if margins is None:
            breaches, margins = fast.check(snapshot(fast))
        want_breaches, want_margins = full.check(snapshot(full))
        assert [str(b) for b in breaches] == [str(b) for b in want_breaches]
        assert margins.keys() == want_margins.keys()
        assert all(a == b or (a != a and b != b) for a, b in zip(margins.values(), want_margins.values()))
        assert (fast.closest, fast.closest_t) == (full.closest, full.closest_t)


@pytest.mark.slow  # reads what the property test above saw
def test_fast_path_was_taken_and_left() -> None:
    """The property test above saw both sides of the fast path."""
    assert any(QUICK) and not all(QUICK)
