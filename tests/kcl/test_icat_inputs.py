"""Bad input to kcl.icat: a ValueError naming the level and what is wrong."""

import numpy as np
import pytest

from kcl.icat import Level, tpik


def good_stack(n=5):
    rng = np.random.default_rng(0)
    return [
        (rng.standard_normal((2, n)), np.array([0.5, 1.0]), np.zeros(2)),
        (rng.standard_normal((1, n)), np.array([1.0]), np.ones(1)),
        (rng.standard_normal((3, n)), np.ones(3), np.ones(3)),
    ]


def with_level(k, **change):
    stack = good_stack()
    J, a, xdot = stack[k]
    parts = {"J": J, "a": a, "xdot": xdot, **change}
    stack[k] = (parts["J"], parts["a"], parts["xdot"])
    return stack


@pytest.mark.parametrize(
    "k, change, pattern",
    [
        (1, {"J": np.ones((1, 4))}, r"level 1: J has 4 columns but level 0 has n = 5"),
        (2, {"a": np.ones(2)}, r"level 2: activation a must have shape \(3,\)"),
        (0, {"xdot": np.zeros(3)}, r"level 0: reference xdot must have shape \(2,\)"),
        (2, {"J": np.ones(5)}, r"level 2: J must be 2-D"),
        (1, {"xdot": np.array([np.nan])}, r"level 1: reference xdot contains NaN or inf"),
        (2, {"J": np.full((3, 5), np.inf)}, r"level 2: J contains NaN or inf"),
        (0, {"a": np.array([0.5, np.nan])}, r"level 0: activation a contains NaN or inf"),
        (2, {"a": np.array([1.0, 1.5, 0.2])}, r"level 2: activation outside \[0, 1\]"),
        (1, {"a": np.array([-1e-3])}, r"level 1: activation outside \[0, 1\]"),
    ],
)
def test_bad_level_is_named(k, change, pattern):
    with pytest.raises(ValueError, match=pattern):
        tpik(with_level(k, **change))


def test_level_name_appears_in_message():
    stack = good_stack()
    J, a, xdot = stack[1]
    stack[1] = Level(J, a, np.array([np.inf]), name="camera centering")
    with pytest.raises(ValueError, match=r"level 1 \(camera centering\): reference xdot"):
        tpik(stack)


def test_not_a_level():
    with pytest.raises(ValueError, match="level 1: expected a \\(J, a, xdot\\) tuple"):
        tpik([good_stack()[0], (1, 2)])
    with pytest.raises(ValueError, match="at least one level"):
        tpik([])


@pytest.mark.parametrize(
    "kwargs, pattern",
    [
        ({"lam": -1.0}, "lam"),
        ({"threshold": 0.0}, "threshold"),
        ({"eta": np.nan}, "eta"),
        ({"limits": np.ones(4)}, r"limits must have shape \(5,\)"),
        ({"limits": -np.ones(5)}, "limits must be >= 0"),
    ],
)
def test_bad_options(kwargs, pattern):
    with pytest.raises(ValueError, match=pattern):
        tpik(good_stack(), **kwargs)


def test_bad_per_level_settings_are_named():
    J, a, xdot = good_stack()[0]
    with pytest.raises(ValueError, match="level 0: threshold"):
        tpik([Level(J, a, xdot, threshold=-1.0)])


def test_lists_are_accepted():
    stack = [([[1.0, 0.0], [0.0, 1.0]], [1.0, 1.0], [0.1, -0.2])]
    np.testing.assert_allclose(tpik(stack), [0.1, -0.2], atol=1e-12)


def test_ragged_input_is_named():
    with pytest.raises(ValueError, match="level 0: J, a and xdot must be numeric arrays"):
        tpik([([[1.0, 2.0], [3.0]], [1.0, 1.0], [0.0, 0.0])])


def test_empty_level_changes_nothing():
    stack = good_stack()
    empty = (np.zeros((0, 5)), np.zeros(0), np.zeros(0))
    expected = tpik(stack, min_velocity=True)
    np.testing.assert_array_equal(tpik([empty] + stack, min_velocity=True), expected)
