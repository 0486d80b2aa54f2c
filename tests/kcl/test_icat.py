"""Mathematical properties of kcl.icat (icat.md, issue 2 part 4)."""

import numpy as np
import oracle as ref
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from kcl.icat import Level, tpik, tpik_trace

SETTINGS = settings(max_examples=60, deadline=None)
seeds = st.integers(0, 2**32 - 1)


def matrix_with_singular_values(rng, m, n, svals):
    """m x n matrix with the given singular values (zeros allowed)."""
    U, _ = np.linalg.qr(rng.standard_normal((m, m)))
    V, _ = np.linalg.qr(rng.standard_normal((n, n)))
    S = np.zeros((m, n))
    k = min(m, n, len(svals))
    S[np.arange(k), np.arange(k)] = svals[:k]
    return U @ S @ V.T


def random_stack(rng, dims, n, a_low=0.0):
    return [(rng.standard_normal((m, n)), rng.uniform(a_low, 1.0, m), rng.standard_normal(m)) for m in dims]


# --- the oracle's icat_pinv (the spec's formula) -------------------------------------------------------------------


@SETTINGS
@given(seed=seeds, m=st.integers(1, 8), n=st.integers(1, 8), rank=st.integers(0, 8))
def test_pinv_is_moore_penrose_without_regularization(seed, m, n, rank):
    rng = np.random.default_rng(seed)
    svals = rng.uniform(0.2, 5.0, min(rank, m, n))
    X = matrix_with_singular_values(rng, m, n, svals)
    got = ref.icat_pinv(X, np.ones(m), np.eye(n), lam=0.0)
    np.testing.assert_allclose(got, np.linalg.pinv(X, rcond=1e-6), atol=1e-9)
    # Penrose conditions
    np.testing.assert_allclose(X @ got @ X, X, atol=1e-9)
    np.testing.assert_allclose(got @ X @ got, got, atol=1e-9)


@SETTINGS
@given(seed=seeds, m=st.integers(1, 6), n=st.integers(1, 9))
def test_pinv_zero_activation_is_zero(seed, m, n):
    rng = np.random.default_rng(seed)
    X = rng.standard_normal((m, n))
    Q = rng.standard_normal((n, n))
    assert np.array_equal(ref.icat_pinv(X, np.zeros(m), Q), np.zeros((n, m)))


# --- zero activations ---------------------------------------------------------------


@SETTINGS
@given(seed=seeds, where=st.integers(0, 4), m0=st.integers(1, 6), use_limits=st.booleans())
def test_all_zero_level_changes_nothing(seed, where, m0, use_limits):
    """A level with a = 0 leaves rho and Q unchanged: inserting it anywhere gives
    bit-identical results, also for every later level's increment."""
    rng = np.random.default_rng(seed)
    n = 9
    stack = random_stack(rng, (2, 1, 3, 2), n)
    dead = (rng.standard_normal((m0, n)), np.zeros(m0), rng.standard_normal(m0))
    limits = rng.uniform(0.05, 1.0, n) if use_limits else None
    with_dead = stack[:where] + [dead] + stack[where:]
    base = tpik_trace(stack, limits=limits, min_velocity=True)
    got = tpik_trace(with_dead, limits=limits, min_velocity=True)
    assert np.array_equal(base.ydot, got.ydot)
    assert got.raw[where] is None and got.applied[where] is None
    for k_base, k_got in zip(range(len(base.raw)), [k for k in range(len(got.raw)) if k != where]):
        assert np.array_equal(base.applied[k_base], got.applied[k_got])


@SETTINGS
@given(seed=seeds)
def test_zero_activation_rows_are_the_same_as_absent_rows(seed):
    rng = np.random.default_rng(seed)
    n = 8
    J = rng.standard_normal((4, n))
    a = np.array([0.0, 0.7, 0.0, 0.3])
    xdot = rng.standard_normal(4)
    rest = random_stack(rng, (2, 3), n)
    full = tpik([(J, a, xdot)] + rest, min_velocity=True)
    reduced = tpik([(J[[1, 3]], a[[1, 3]], xdot[[1, 3]])] + rest, min_velocity=True)
    np.testing.assert_allclose(full, reduced, atol=1e-12)
    np.testing.assert_allclose(full, ref.tpik([(J, a, xdot)] + rest, min_velocity=True), atol=1e-9)


# --- scalar task: J rho = a^2 xdot ---------------------------------------------------------


@SETTINGS
@given(seed=seeds, a=st.floats(0.05, 1.0), xdot=st.floats(-5, 5), n=st.integers(1, 10))
def test_scalar_task_achieves_a_squared_xdot(seed, a, xdot, n):
    rng = np.random.default_rng(seed)
    x = rng.standard_normal(n)
    x *= rng.uniform(0.7, 3.0) / np.linalg.norm(x)  # a |x|^2 > threshold: no regularization
    y = tpik([(x[None, :], np.array([a]), np.array([xdot]))])
    assert x @ y == pytest.approx(a * a * xdot, abs=1e-9)


@pytest.mark.slow  # seconds long: the full suite runs it, test-fast does not
def test_scalar_task_is_continuous_in_activation_down_to_zero():
    rng = np.random.default_rng(7)
    x = rng.standard_normal(6)
    x /= np.linalg.norm(x)
    acts = np.linspace(0.0, 1.0, 20001)
    achieved = np.array([x @ tpik([(x[None, :], np.array([a]), np.array([1.0]))]) for a in acts])
    assert achieved[0] == 0.0 and achieved[-1] == pytest.approx(1.0, abs=1e-12)
    # steps of 5e-5 in a never move the achieved rate by more than a small multiple
    assert np.max(np.abs(np.diff(achieved))) < 50 * (acts[1] - acts[0])
    # and the regularization only ever reduces it below a^2
    assert np.all(achieved <= acts**2 + 1e-12) and np.all(achieved >= 0.0)


# --- strict priority -----------------------------------------------------------------------


@SETTINGS
@given(seed=seeds, m1=st.integers(1, 6), lower=st.lists(st.integers(1, 6), max_size=5), minvel=st.booleans())
def test_active_top_level_is_tracked_whatever_lower_levels_ask(seed, m1, lower, minvel):
    rng = np.random.default_rng(seed)
    n = 10
    J1 = matrix_with_singular_values(rng, m1, n, rng.uniform(0.3, 3.0, m1))
    xdot1 = rng.uniform(-2, 2, m1)
    stack = [(J1, np.ones(m1), xdot1)]
    for m in lower:  # conflicting lower levels with huge references
        stack.append((rng.standard_normal((m, n)), rng.uniform(0, 1, m), 100 * rng.standard_normal(m)))
    y = tpik(stack, min_velocity=minvel)
    np.testing.assert_allclose(J1 @ y, xdot1, atol=1e-6)


@SETTINGS
@given(seed=seeds)
def test_second_level_tracked_in_remaining_freedom(seed):
    rng = np.random.default_rng(seed)
    n = 9
    J1 = matrix_with_singular_values(rng, 3, n, rng.uniform(0.5, 2, 3))
    J2 = matrix_with_singular_values(rng, 4, n, rng.uniform(0.5, 2, 4))
    x1, x2 = rng.standard_normal(3), rng.standard_normal(4)
    # make level 2 compatible with level 1 through the remaining freedom
    if np.linalg.svd(np.vstack([J1, J2]), compute_uv=False)[-1] < 0.2:
        return
    y = tpik(
        [(J1, np.ones(3), x1), (J2, np.ones(4), x2), (rng.standard_normal((5, n)), np.ones(5), rng.standard_normal(5))],
        min_velocity=True,
    )
    np.testing.assert_allclose(J1 @ y, x1, atol=1e-6)
    np.testing.assert_allclose(J2 @ y, x2, atol=1e-6)


# --- minimum velocity level -------------------------------------------------------------


@SETTINGS
@given(seed=seeds, a=st.floats(0.2, 0.85))  # (1 - a)^2 > threshold: no damping
def test_min_velocity_level_really_runs(seed, a):
    """Scalar task then J = I: closed form J y = a^2 xdot * a^2 / (a^2 + (1 - a)^2)."""
    rng = np.random.default_rng(seed)
    n = 7
    x = rng.standard_normal(n)
    x /= np.linalg.norm(x)
    lv = (x[None, :], np.array([a]), np.array([1.5]))
    without = tpik([lv])
    with_mv = tpik([lv], min_velocity=True)
    explicit = tpik([lv, (np.eye(n), np.ones(n), np.zeros(n))])
    assert x @ without == pytest.approx(a * a * 1.5, abs=1e-9)
    expect = a * a * 1.5 * a * a / (a * a + (1 - a) ** 2)
    assert x @ with_mv == pytest.approx(expect, abs=1e-9)
    np.testing.assert_allclose(with_mv, explicit, rtol=0, atol=1e-12)


# --- continuity --------------------------------------------------------------------------


@settings(max_examples=40, deadline=None)
@given(seed=seeds, what=st.sampled_from(["a", "xdot"]), h=st.sampled_from([1e-9, 1e-10]))
def test_lipschitz_in_activations_and_references(seed, what, h):
    rng = np.random.default_rng(seed)
    n = 13
    stack = random_stack(rng, (1, 1, 3, 6, 2), n)
    limits = rng.uniform(0.2, 2.0, n)
    perturbed = []
    for J, a, xdot in stack:
        d = rng.uniform(-1, 1, a.shape) * h
        if what == "a":
            perturbed.append((J, np.clip(a + d, 0, 1), xdot))
        else:
            perturbed.append((J, a, xdot + d))
    for lim in (None, limits):
        y0 = tpik(stack, limits=lim, min_velocity=True)
        y1 = tpik(perturbed, limits=lim, min_velocity=True)
        # Smooth activations and the damped gains keep the ratio small (~35 at
        # worst over 800 random stacks; the damping allows up to ~1/lam); a
        # jump of even 1e-4 in the output would show as a ratio >= 1e5 here.
        assert np.linalg.norm(y1 - y0) <= 1e4 * h * max(1.0, np.linalg.norm(y0))


@SETTINGS
@given(seed=seeds, k=st.integers(0, 3))
def test_switching_a_level_off_is_continuous(seed, k):
    """activation 1e-9 versus exactly 0 (level skipped): nearly the same output."""
    rng = np.random.default_rng(seed)
    n = 10
    stack = random_stack(rng, (2, 1, 3, 2), n)
    J, a, xdot = stack[k]
    on = list(stack)
    on[k] = (J, np.full_like(a, 1e-9), xdot)
    off = list(stack)
    off[k] = (J, np.zeros_like(a), xdot)
    y_on, y_off = tpik(on, min_velocity=True), tpik(off, min_velocity=True)
    assert np.linalg.norm(y_on - y_off) <= 1e-6 * max(1.0, np.linalg.norm(y_off))


# --- saturation ------------------------------------------------------------------------


@SETTINGS
@given(seed=seeds, scale=st.floats(0.01, 3.0), minvel=st.booleans())
def test_saturation_respects_limits_and_keeps_directions(seed, scale, minvel):
    rng = np.random.default_rng(seed)
    n = 11
    stack = random_stack(rng, (1, 3, 2, 6), n)
    limits = scale * rng.uniform(0.1, 1.0, n)
    limits[rng.integers(n)] = 0.0  # a locked DOF
    tr = tpik_trace(stack, limits=limits, min_velocity=minvel)
    assert np.all(np.abs(tr.ydot) <= limits * (1 + 1e-12))
    assert tr.ydot[limits == 0.0].tolist() == [0.0]
    total = np.zeros(n)
    for raw, applied, factor in zip(tr.raw, tr.applied, tr.factors):
        assert 0.0 <= factor <= 1.0
        np.testing.assert_allclose(applied, factor * raw, rtol=0, atol=1e-15)
        total += applied
    assert 0.0 <= tr.final_scale <= 1.0
    np.testing.assert_allclose(tr.ydot, tr.final_scale * total, atol=1e-14)
    np.testing.assert_allclose(tr.ydot, ref.tpik(stack, limits=limits, min_velocity=minvel), atol=1e-9)


@SETTINGS
@given(seed=seeds)
def test_single_level_saturation_is_uniform_scaling(seed):
    rng = np.random.default_rng(seed)
    n = 8
    stack = random_stack(rng, (3,), n)
    free = tpik(stack)
    limits = rng.uniform(0.01, 1.0, n) * np.abs(free).max()
    y = tpik(stack, limits=limits)
    s = min(1.0, float(np.min(limits / np.abs(free))))
    np.testing.assert_allclose(y, s * free, atol=1e-12)


@SETTINGS
@given(seed=seeds)
def test_loose_limits_change_nothing(seed):
    rng = np.random.default_rng(seed)
    stack = random_stack(rng, (1, 2, 4), 9)
    free = tpik(stack, min_velocity=True)
    assert np.array_equal(tpik(stack, limits=np.full(9, np.inf), min_velocity=True), free)
    np.testing.assert_allclose(
        tpik(stack, limits=100 * np.abs(free).max() * np.ones(9), min_velocity=True), free, atol=1e-12
    )


# --- underactuation ----------------------------------------------------------------------


@SETTINGS
@given(seed=seeds, mask=st.lists(st.booleans(), min_size=6, max_size=6), l=st.integers(1, 7))
def test_measured_velocity_task_pins_non_actuated_dofs(seed, mask, l):
    rng = np.random.default_rng(seed)
    n = l + 6
    v_meas = rng.uniform(-0.5, 0.5, 6)
    J_top = np.hstack([np.zeros((6, l)), np.eye(6)])
    a_top = np.array(mask, dtype=float)
    stack = [(J_top, a_top, v_meas)] + random_stack(rng, (3, 1, 6, 2), n)
    for k in range(1, len(stack)):  # lower levels ask for large, conflicting motion
        J, a, xdot = stack[k]
        stack[k] = (J, a, 10 * xdot)
    y = tpik(stack, min_velocity=True)
    pinned = np.flatnonzero(a_top)
    np.testing.assert_allclose(y[l + pinned], v_meas[pinned], atol=1e-9)


# --- per-level settings and the Level type ---------------------------------------------------


def test_level_objects_and_per_level_regularization():
    rng = np.random.default_rng(3)
    n = 6
    J = matrix_with_singular_values(rng, 2, n, [1.0, 0.05])  # one direction inside th
    a, xdot = np.ones(2), np.array([1.0, 1.0])
    plain = tpik([(J, a, xdot)])
    assert np.array_equal(tpik([Level(J, a, xdot)]), plain)
    strong = tpik([Level(J, a, xdot, lam=1e-1, threshold=0.5)])
    np.testing.assert_allclose(strong, ref.tpik([Level(J, a, xdot, lam=1e-1, threshold=0.5)]), atol=1e-12)
    assert np.linalg.norm(strong) < np.linalg.norm(plain)  # stronger damping, slower
    # threshold below the smallest eigenvalue (0.05^2): exact inverse
    exact = tpik([Level(J, a, xdot, lam=1e-1, threshold=1e-3)])
    np.testing.assert_allclose(J @ exact, xdot, atol=1e-9)
