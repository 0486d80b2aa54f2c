"""kcl.small_linalg.sym_eig: eigendecomposition of small symmetric matrices
(the TPIK kernel's eigen path) against LAPACK, including the degenerate
matrices the kernel meets: rank deficient, tiny eigenvalues, diagonal ones,
columns that are already nearly tridiagonal."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from kcl.small_linalg import sym_eig


def check(M: np.ndarray) -> None:
    ok, s, V = sym_eig(M)
    assert ok
    n = M.shape[0]
    scale = max(1.0, float(np.abs(M).max()))
    np.testing.assert_allclose((V * s) @ V.T, M, rtol=0, atol=1e-13 * scale)
    np.testing.assert_allclose(V.T @ V, np.eye(n), rtol=0, atol=1e-13)
    np.testing.assert_allclose(np.sort(s), np.linalg.eigvalsh(M), rtol=0, atol=1e-13 * scale)


@settings(max_examples=100, deadline=None)
@given(
    seed=st.integers(0, 2**32 - 1),
    n=st.integers(1, 14),
    kind=st.sampled_from(["symmetric", "gram", "rank_deficient", "clustered", "diagonal", "scaled"]),
)
def test_sym_eig_matches_lapack(seed, n, kind):
    rng = np.random.default_rng(seed)
    A = rng.standard_normal((n, n))
    if kind == "symmetric":
        M = A + A.T
    elif kind == "gram":
        M = A @ A.T
    elif kind == "rank_deficient":
        B = rng.standard_normal((int(rng.integers(0, n + 1)), n))
        M = B.T @ B
    elif kind == "clustered":  # repeated and tiny eigenvalues
        U, _ = np.linalg.qr(A)
        M = (U * rng.choice([0.0, 1e-12, 1e-6, 1.0, 1.0], n)) @ U.T
    elif kind == "diagonal":
        M = np.diag(rng.standard_normal(n))
    else:
        M = (A @ A.T) * 10.0 ** rng.uniform(-8, 4)
    check(M)


def test_nearly_tridiagonal_column_is_still_reduced():
    """A column whose entries below the sub-diagonal are tiny next to it
    (here 4e-9 beside 1.4) must still be reduced: summing them apart from the
    sub-diagonal entry avoids the cancellation that once skipped it (the
    reconstruction error was then 4e-9)."""
    M = np.array(
        [
            [1.9344938997813581, 1.3917341210029017, -4.3877607571734352e-09],
            [1.3917341210029017, 2.1916714573197602, 1.6954006438728172e-08],
            [-4.3877607571734352e-09, 1.6954006438728172e-08, 3.4969922721259508e-16],
        ]
    )
    check(M)


@pytest.mark.parametrize("n", [1, 2, 5])
def test_zero_and_identity(n):
    check(np.zeros((n, n)))
    check(np.eye(n))
