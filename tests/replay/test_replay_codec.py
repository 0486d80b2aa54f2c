"""Input records: readings survive JSON bit for bit, exceptions keep type and message,
the new channels' schemas load in Foxglove (no type unions, properties everywhere)."""

from __future__ import annotations

import math

import numpy as np
import orjson
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from hal.interfaces import (
    Detection,
    GripperMotion,
    GripperState,
    Health,
    HealthState,
    JointState,
    NavigationState,
    Wrench,
)
from mission.logs.channels import CHANNELS, schema_problems
from mission.replay import codec, steplog
from mission.replay.schema import REPLAY_CHANNELS

anyfloat = st.floats(allow_nan=True, allow_infinity=True, allow_subnormal=True)


def same_bits(a, b) -> bool:
    """Bit equality of two float arrays or scalars (any NaN equals any NaN)."""
    a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    if a.shape != b.shape:
        return False
    nan = np.isnan(a) & np.isnan(b)
    return bool(np.all(nan | (a.view(np.uint64) == b.view(np.uint64))))


def roundtrip(encode, decode, value):
    return decode(orjson.loads(codec.dumps(encode(value))))


@settings(max_examples=200, deadline=None)
@given(st.lists(anyfloat, min_size=16, max_size=16), st.booleans(), st.booleans())
def test_navigation_roundtrip_is_bit_exact(xs, has_vel, has_alt):
    nav = NavigationState(
        t=xs[0],
        position=np.array(xs[1:4]),
        attitude=np.array(xs[4:7]),
        body_velocity=np.array(xs[7:13]) if has_vel else None,
        velocity_t=xs[13] if has_vel else None,
        depth=xs[14],
        altitude=xs[15] if has_alt else None,
    )
    back = roundtrip(codec.enc_navigation, codec.dec_navigation, nav)
    for name in ("t", "position", "attitude", "depth"):
        assert same_bits(getattr(nav, name), getattr(back, name)), name
    assert (back.body_velocity is None) == (not has_vel) and (back.altitude is None) == (not has_alt)
    if has_vel:
        assert same_bits(nav.body_velocity, back.body_velocity) and same_bits(nav.velocity_t, back.velocity_t)
    if has_alt:
        assert same_bits(nav.altitude, back.altitude)
    assert not back.position.flags.writeable  # a replayed reading cannot be changed in place


def test_negative_zero_nan_and_infinities_come_back():
    js = JointState(
        t=0.5,
        position=np.array([-0.0, np.nan, np.inf, -np.inf]),
        velocity=np.zeros(4),
        current=np.array([1e-310, 5e-324, 1.7976931348623157e308, 0.1]),
        fault="j2: overcurrent",
    )
    rec = orjson.loads(codec.dumps(codec.enc_joints(js)))
    assert rec["position"][1:] == [None, None, None] and rec["nonfinite"] == [
        "position.1=nan",
        "position.2=inf",
        "position.3=-inf",
    ]
    back = codec.dec_joints(rec)
    assert same_bits(back.position, js.position) and math.copysign(1, back.position[0]) == -1
    assert same_bits(back.current, js.current) and back.fault == "j2: overcurrent"


def test_other_readings_roundtrip():
    gs = GripperState(
        t=1.0, positions=np.array([0.1, 0.2, 0.3]), currents=np.array([1.0, 2.0, 3.0]), motion=GripperMotion.HOLDING
    )
    back = roundtrip(codec.enc_gripper, codec.dec_gripper, gs)
    assert back.motion is GripperMotion.HOLDING and back.fault is None and same_bits(back.currents, gs.currents)
    w = Wrench(t=2.0, force=np.array([1.0, -2.0, np.nan]), torque=np.zeros(3))
    assert same_bits(roundtrip(codec.enc_wrench, codec.dec_wrench, w).force, w.force)
    assert roundtrip(codec.enc_wrench, codec.dec_wrench, None) is None
    pose = np.eye(4)
    pose[0, 3] = np.nan
    det = roundtrip(codec.enc_detection, codec.dec_detection, Detection(t=3.0, pose=pose, confidence=0.7))
    assert det.pose.shape == (4, 4) and same_bits(det.pose, pose) and det.confidence == 0.7 and det.details is None
    details = {"visible_end": "left", "edges": [[1.0, 2.5], [3.0, 4.0]], "quality": {"contrast": 0.8}}
    det = roundtrip(
        codec.enc_detection, codec.dec_detection, Detection(t=3.0, pose=np.eye(4), confidence=0.9, details=details)
    )
    assert det.details == details
    h = Health(HealthState.DEGRADED, 4.0, "DVL: no bottom lock", {"dvl_age_s": None, "rate_hz": 8.5})
    back = roundtrip(codec.enc_health, codec.dec_health, h)
    assert back == h


def test_float32_readings_are_recorded_as_the_float64_they_become():
    js = JointState(t=0.0, position=np.array([0.1, 0.2], dtype=np.float32), velocity=np.zeros(2), current=np.zeros(2))
    back = roundtrip(codec.enc_joints, codec.dec_joints, js)
    assert same_bits(back.position, js.position.astype(float))


@pytest.mark.parametrize(
    "exc", [OSError("CAN interface can0 is down"), KeyError("j3"), TimeoutError("no SDO answer"), RuntimeError("")]
)
def test_exceptions_rebuilt_with_type_name_and_message(exc):
    fields = codec.error_fields(exc)
    again = codec.rebuild_error(fields["error_type"], fields["error"])
    assert type(again).__name__ == type(exc).__name__ and str(again) == str(exc)
    assert isinstance(again, type(exc)) and getattr(again, "replayed", False)


def test_unknown_exception_type_is_an_exception_of_that_name():
    again = codec.rebuild_error("CanOperationError", "bus off")
    assert type(again).__name__ == "CanOperationError" and str(again) == "bus off" and isinstance(again, Exception)


def test_replay_channels_are_registered_and_foxglove_friendly():
    for topic, (name, schema) in REPLAY_CHANNELS.items():
        assert CHANNELS[topic] == (name, schema)
        assert schema_problems(schema) == [], topic


_values = st.one_of(
    anyfloat,
    st.integers(-3, 3),
    st.booleans(),
    st.none(),
    st.text(max_size=8),
    st.just("null"),
    st.lists(anyfloat, max_size=5),
    st.lists(st.one_of(anyfloat, st.none()), max_size=4),
    st.lists(anyfloat, min_size=1, max_size=6).map(lambda xs: np.array(xs, dtype=float)),
    st.lists(anyfloat, min_size=4, max_size=4).map(lambda xs: np.array(xs, dtype=float).reshape(2, 2)),
)


@pytest.mark.slow
@settings(max_examples=300, deadline=None)
@given(st.dictionaries(st.sampled_from(["call", "k", "t", "position", "info", "values", "pose"]), _values, max_size=5))
def test_has_nonfinite_tells_when_marking_changes_the_bytes(rec):
    """The input record's batch writer keeps records that :func:`codec.has_nonfinite` finds
    clean instead of marking them: their marked copy must encode to the same bytes."""
    marked = codec.mark_nonfinite(rec)
    assert codec.has_nonfinite(rec) == ("nonfinite" in marked)
    if not codec.has_nonfinite(rec):
        dump = lambda r: orjson.dumps(r, default=codec.default, option=codec.OPTIONS)  # noqa: E731
        assert dump(marked) == dump(rec)


_texts_with_null = st.dictionaries(
    st.sampled_from(["a", "age_s", "x"]), st.one_of(st.none(), anyfloat), max_size=3
).map(lambda d: orjson.dumps(d).decode())


@pytest.mark.slow
@settings(max_examples=300, deadline=None)
@given(
    st.lists(
        st.dictionaries(
            st.sampled_from(["call", "k", "t", "position", "info", "values"]),
            st.one_of(_values, _texts_with_null),
            max_size=5,
        ),
        max_size=4,
    )
)
def test_a_batch_with_a_nonfinite_number_is_always_looked_at(batch):
    """The batch writer skips the record-by-record look only when every ``null`` of the
    encoded batch sits in a text (a health info's JSON): never when a record holds a
    non-finite number, whatever its texts say."""
    data = orjson.dumps(batch, default=codec.default, option=codec.OPTIONS)
    if any(codec.has_nonfinite(rec) for rec in batch):
        assert steplog._may_hold_nonfinite(data)
