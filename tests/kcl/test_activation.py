"""Activation functions (kcl.activation) and action transitions (kcl.blend)
against the formulas of icat.md."""

import math

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from kcl.actions import load_actions
from kcl.activation import action_transition_factor, decreasing_bell, increasing_bell
from kcl.blend import ActionBlend

finite = st.floats(-1e3, 1e3, allow_nan=False)
SETTINGS = settings(max_examples=80, deadline=None)


def breakpoints():
    return st.tuples(finite, st.floats(1e-3, 1e2)).map(lambda t: (t[0], t[0] + t[1]))


@SETTINGS
@given(x=finite, bp=breakpoints())
def test_bells_match_formula_and_are_complementary(x, bp):
    xmin, xmax = bp
    dec = decreasing_bell(x, xmin, xmax)
    inc = increasing_bell(x, xmin, xmax)
    if x <= xmin:
        assert dec == 1.0 and inc == 0.0
    elif x >= xmax:
        assert dec == 0.0 and inc == 1.0
    else:
        u = (x - xmin) / (xmax - xmin)
        assert dec == pytest.approx(0.5 * math.cos(math.pi * u) + 0.5, abs=1e-12)
        assert inc == pytest.approx(0.5 * math.cos(math.pi * u + math.pi) + 0.5, abs=1e-12)
    assert 0.0 <= dec <= 1.0 and 0.0 <= inc <= 1.0
    assert dec + inc == pytest.approx(1.0, abs=1e-12)


@SETTINGS
@given(bp=breakpoints(), u1=st.floats(0, 1), u2=st.floats(0, 1))
def test_bells_monotone_and_lipschitz(bp, u1, u2):
    xmin, xmax = bp
    x1, x2 = sorted((xmin + u1 * (xmax - xmin), xmin + u2 * (xmax - xmin)))
    assert increasing_bell(x1, xmin, xmax) <= increasing_bell(x2, xmin, xmax) + 1e-15
    assert decreasing_bell(x1, xmin, xmax) >= decreasing_bell(x2, xmin, xmax) - 1e-15
    # slope of the raised cosine is at most pi / (2 (xmax - xmin))
    slope_bound = math.pi / (2 * (xmax - xmin))
    diff = abs(increasing_bell(x2, xmin, xmax) - increasing_bell(x1, xmin, xmax))
    assert diff <= slope_bound * (x2 - x1) + 1e-12


def test_bells_flat_at_the_ends_c1():
    h = 1e-6
    for f in (increasing_bell, decreasing_bell):
        for x0 in (0.0, 1.0):
            slope = (f(x0 + h, 0.0, 1.0) - f(x0 - h, 0.0, 1.0)) / (2 * h)
            assert abs(slope) < 1e-5
        assert f(0.5, 0.0, 1.0) == pytest.approx(0.5, abs=1e-15)


def test_nan_propagates():
    assert math.isnan(increasing_bell(math.nan, 0.0, 1.0))
    assert math.isnan(decreasing_bell(math.nan, 0.0, 1.0))


@SETTINGS
@given(t=st.floats(-1, 5), T=st.floats(1e-3, 3))
def test_action_transition_factor_is_the_specs_bells(t, T):
    entering = action_transition_factor(0.0, 1.0, t, T)
    leaving = action_transition_factor(1.0, 0.0, t, T)
    assert entering == increasing_bell(t, 0.0, T)
    assert leaving == pytest.approx(decreasing_bell(t, 0.0, T), abs=1e-15)
    assert entering + leaving == pytest.approx(1.0, abs=1e-12)
    assert action_transition_factor(1.0, 1.0, t, T) == 1.0
    assert action_transition_factor(0.0, 0.0, t, T) == 0.0
    if t <= 0:
        assert entering == 0.0 and leaving == 1.0
    if t >= T:
        assert entering == 1.0 and leaving == 0.0


def test_action_transition_default_time_and_instant_switch():
    assert action_transition_factor(0.0, 1.0, 0.25) == pytest.approx(0.5)  # T defaults to 0.5 s
    assert action_transition_factor(1.0, 0.0, 0.5) == 0.0
    assert action_transition_factor(0.0, 1.0, 0.0, 0.0) == 1.0
    assert action_transition_factor(1.0, 0.0, 0.0, 0.0) == 0.0


@pytest.fixture(scope="module")
def actions():
    return load_actions()


@SETTINGS
@given(t1=st.floats(0.0, 0.6), dt=st.floats(0.0, 1.0))
def test_blend_factors_follow_eq13_and_stay_continuous_across_switches(actions, t1, dt):
    """In a transition every task's factor is the spec's a_p from its value at the
    switch; a second switch mid-transition starts from the current factors."""
    blend = ActionBlend(actions)
    T = blend.transition_time
    blend.set_action("survey", 0.0)
    survey = set(actions.tasks_of("survey"))
    for name, f in zip(blend.names, blend.factors_at(t1)):
        assert f == pytest.approx(action_transition_factor(0.0, 1.0 if name in survey else 0.0, t1, T), abs=1e-15)
    before = blend.factors_at(t1).copy()
    blend.set_action("grasp", t1)
    assert blend.factors_at(t1) == pytest.approx(before, abs=1e-15)  # continuous at the switch
    grasp = set(actions.tasks_of("grasp"))
    for name, start, f in zip(blend.names, before, blend.factors_at(t1 + dt)):
        end = 1.0 if name in grasp else 0.0
        assert f == pytest.approx(action_transition_factor(start, end, dt, T), abs=1e-15)
        assert min(start, end) - 1e-15 <= f <= max(start, end) + 1e-15


def test_blend_steady_factors_are_the_action_and_one_array(actions):
    blend = ActionBlend(actions)
    blend.set_action("hold", 0.0)
    steady = blend.factors_at(10.0)
    assert steady is blend.factors_at(11.0)  # unchanged object while nothing moves
    assert {n for n, f in zip(blend.names, steady) if f == 1.0} == set(actions.tasks_of("hold"))
    assert blend.progress(0.25) == pytest.approx(0.5) and blend.progress(3.0) == 1.0
    blend.stop()
    blend.set_action("hold", 20.0)  # after a stop, the same action fades in again from zero
    assert not blend.factors_at(20.0).any()
    with pytest.raises(KeyError, match="unknown action"):
        blend.set_action("dance", 21.0)
