"""kcl.icat (the compiled recursion) equals the plain transcription of icat.md
(tests/kcl/oracle.py) to 1e-9 on random stacks, including degenerate ones."""

import threading

import numpy as np
import oracle as ref
from hypothesis import given, settings
from hypothesis import strategies as st

from kcl.icat import Level, tpik

seeds = st.integers(0, 2**32 - 1)


def degenerate_level(rng, kind, m, n):
    J = rng.standard_normal((m, n))
    a = rng.uniform(0, 1, m)
    xdot = rng.standard_normal(m)
    if kind == "rank_deficient" and m > 1:
        J[-1] = J[0] * rng.uniform(-2, 2)  # duplicated (scaled) row
    elif kind == "zero_columns":
        J[:, rng.integers(n, size=3)] = 0.0
    elif kind == "zero_rows":
        J[rng.integers(m)] = 0.0
    elif kind == "all_zero":
        a[:] = 0.0
    elif kind == "some_zero":
        a[rng.random(m) < 0.5] = 0.0
    elif kind == "tiny":
        a = 10.0 ** rng.uniform(-7, -1, m)  # through the regularization region
    elif kind == "full":
        a[:] = 1.0
    elif kind == "small_jacobian":
        J *= 10.0 ** rng.uniform(-4, -1)
    return J, a, xdot


kinds = st.sampled_from(
    ["plain", "rank_deficient", "zero_columns", "zero_rows", "all_zero", "some_zero", "tiny", "full", "small_jacobian"]
)


@settings(max_examples=100, deadline=None)
@given(
    seed=seeds,
    dims=st.lists(st.integers(1, 8), min_size=1, max_size=9),
    level_kinds=st.lists(kinds, min_size=9, max_size=9),
    n=st.integers(1, 14),
    minvel=st.booleans(),
    use_limits=st.booleans(),
    eta=st.sampled_from([1.0, 0.0, 2.5]),
)
def test_fast_equals_reference(seed, dims, level_kinds, n, minvel, use_limits, eta):
    rng = np.random.default_rng(seed)
    stack = [degenerate_level(rng, k, m, n) for m, k in zip(dims, level_kinds)]
    limits = rng.uniform(0.0, 1.5, n) if use_limits else None
    slow = ref.tpik(stack, limits=limits, min_velocity=minvel, eta=eta)
    fast = tpik(stack, limits=limits, min_velocity=minvel, eta=eta)
    np.testing.assert_allclose(fast, slow, rtol=0, atol=1e-9)


@settings(max_examples=30, deadline=None)
@given(seed=seeds)
def test_benchmark_pass_equals_reference(seed):
    rng = np.random.default_rng(seed)
    n = 13
    stack = [
        (rng.standard_normal((m, n)), rng.uniform(0, 1, m), rng.standard_normal(m)) for m in (1, 1, 1, 3, 6, 1, 6, 3)
    ]
    slow = ref.tpik(stack, min_velocity=True)
    np.testing.assert_allclose(tpik(stack, min_velocity=True), slow, rtol=0, atol=1e-9)


@settings(max_examples=30, deadline=None)
@given(
    seed=seeds,
    lams=st.lists(st.sampled_from([0.0, 1e-4, 1e-2, 0.3]), min_size=4, max_size=4),
    ths=st.lists(st.sampled_from([1e-3, 1e-2, 0.2]), min_size=4, max_size=4),
)
def test_per_level_settings_equal_reference(seed, lams, ths):
    rng = np.random.default_rng(seed)
    n = 9
    stack = [
        Level(rng.standard_normal((m, n)), rng.uniform(0, 1, m), rng.standard_normal(m), lam=lam, threshold=th)
        for m, lam, th in zip((1, 3, 2, 5), lams, ths)
    ]
    slow = ref.tpik(stack, min_velocity=True)
    np.testing.assert_allclose(tpik(stack, min_velocity=True), slow, rtol=0, atol=1e-9)


def test_concurrent_threads_give_the_same_results():
    """The compiled recursion keeps no state between calls: threads agree."""
    rng = np.random.default_rng(5)
    stacks = [[degenerate_level(rng, "plain", m, 13) for m in (1, 3, 6, 2)] for _ in range(8)]
    expected = [ref.tpik(s, min_velocity=True) for s in stacks]

    def check_all(failures):
        for _ in range(20):
            for s, e in zip(stacks, expected):
                if np.max(np.abs(tpik(s, min_velocity=True) - e)) > 1e-9:
                    failures.append(1)

    failures: list = []
    threads = [threading.Thread(target=check_all, args=(failures,)) for _ in range(4)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert not failures
