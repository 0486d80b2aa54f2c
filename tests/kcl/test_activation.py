"""Activation functions (kcl.activation) against the formulas of icat.md."""

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from kcl.activation import (
    a_p,
    action_transition_factor,
    decreasing_bell,
    increasing_bell,
    lower_bound_activation,
    upper_bound_activation,
)

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
@given(xs=st.lists(finite, min_size=1, max_size=20), bp=breakpoints())
def test_vectorised_equals_scalar_path(xs, bp):
    xmin, xmax = bp
    arr = np.array(xs)
    np.testing.assert_allclose(
        decreasing_bell(arr, xmin, xmax), [decreasing_bell(x, xmin, xmax) for x in xs], atol=1e-12
    )
    np.testing.assert_allclose(
        increasing_bell(arr, xmin, xmax), [increasing_bell(x, xmin, xmax) for x in xs], atol=1e-12
    )


def test_bells_broadcast_over_breakpoint_arrays():
    x = np.array([0.0, 0.5, 2.0])
    out = increasing_bell(x, np.array([0.0, 0.0, 0.0]), np.array([1.0, 1.0, 1.0]))
    np.testing.assert_allclose(out, [0.0, 0.5, 1.0], atol=1e-15)


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


@pytest.mark.parametrize("xmin, xmax", [(1.0, 1.0), (2.0, 1.0)])
def test_bells_reject_empty_interval(xmin, xmax):
    with pytest.raises(ValueError, match="xmin < xmax"):
        increasing_bell(0.0, xmin, xmax)
    with pytest.raises(ValueError, match="xmin < xmax"):
        decreasing_bell(np.zeros(3), xmin, xmax)


def test_nan_propagates():
    assert math.isnan(increasing_bell(math.nan, 0.0, 1.0))
    assert np.isnan(decreasing_bell(np.array([np.nan]), 0.0, 1.0)).all()


@SETTINGS
@given(x=finite, xmin=finite, width=st.floats(1e-3, 1e2))
def test_lower_bound_activation(x, xmin, width):
    a, xbar = lower_bound_activation(x, xmin, width)
    assert xbar == xmin + width
    if x <= xmin:
        assert a == 1.0  # violated or at the bound: fully active
    elif x >= xmin + width:
        assert a == 0.0  # well inside the satisfied region: off
    assert a == decreasing_bell(x, xmin, xmin + width)


@SETTINGS
@given(x=finite, xmax=finite, width=st.floats(1e-3, 1e2))
def test_upper_bound_activation(x, xmax, width):
    a, xbar = upper_bound_activation(x, xmax, width)
    assert xbar == xmax - width
    if x >= xmax:
        assert a == 1.0
    elif x <= xmax - width:
        assert a == 0.0
    assert a == increasing_bell(x, xmax - width, xmax)


def test_inequality_activation_vectorised_and_width_checked():
    a, xbar = lower_bound_activation(np.array([0.0, 0.25, 1.0]), np.array([0.0, 0.0, 0.0]), 0.5)
    np.testing.assert_allclose(a, [1.0, 0.5, 0.0], atol=1e-15)
    np.testing.assert_allclose(xbar, 0.5)
    with pytest.raises(ValueError, match="width"):
        upper_bound_activation(0.0, 1.0, 0.0)


@SETTINGS
@given(t=st.floats(-1, 5), T=st.floats(1e-3, 3))
def test_action_transition_factor(t, T):
    entering = action_transition_factor(False, True, t, T)
    leaving = action_transition_factor(True, False, t, T)
    assert entering == increasing_bell(t, 0.0, T)
    assert leaving == decreasing_bell(t, 0.0, T)
    assert entering + leaving == pytest.approx(1.0, abs=1e-12)
    assert action_transition_factor(True, True, t, T) == 1.0
    assert action_transition_factor(False, False, t, T) == 0.0
    if t <= 0:
        assert entering == 0.0 and leaving == 1.0
    if t >= T:
        assert entering == 1.0 and leaving == 0.0


def test_action_transition_default_time_and_alias():
    assert a_p is action_transition_factor
    assert a_p(False, True, 0.25) == pytest.approx(0.5)  # T defaults to 0.5 s
    assert a_p(True, False, 0.5) == 0.0
    assert a_p(False, True, 0.0, 0.0) == 1.0 and a_p(True, False, 0.0, 0.0) == 0.0
    with pytest.raises(ValueError, match="transition time"):
        a_p(False, True, 0.1, -1.0)
