"""Small dense linear algebra for the TPIK kernel, compiled (Numba).

The KCL's matrices are tiny (at most ~13 x 13): LAPACK through
``numpy.linalg`` inside Numba spends most of its time in the wrapper
(workspace query and allocation, copy to Fortran order, NaN check): 8-30 us
for a 7 x 7 to 13 x 13 eigendecomposition here. These loops do the work
directly:

* :func:`sym_eig` - ``M = V diag(s) V^T`` of a symmetric M: Householder
  reduction to tridiagonal form (Q accumulated), then implicit symmetric QR
  steps with Wilkinson shifts (Givens rotations, bulge chasing, deflation when
  an off-diagonal entry falls below ``eps (|d_i| + |d_{i+1}|)``). Backward
  stable like LAPACK's ``dsyev``: the pairs are exact for a matrix within a
  few ``eps ||M||`` of M. Eigenvalues come out in no particular order (callers
  apply a function elementwise). If the QR iteration does not converge within
  ``30 n`` steps (never seen; a guard against NaN input) it reports it and the
  caller uses ``numpy.linalg.eigh``.
* :func:`cholesky_above`, :func:`cholesky_solve`, :func:`well_conditioned_factor`
  - Cholesky factorization (also as the test "every eigenvalue > th") and solve.
* :func:`extend_basis` - Gram-Schmidt extension of an orthonormal basis.
* :func:`matvec_into`, :func:`mul_abt_into`, :func:`mul_sparse_into`,
  :func:`sym_cross_into` - the products of the recursion, on the leading
  blocks of preallocated buffers.
* :func:`gram_sqrt_det` - ``sqrt(det(J J^T))`` (the arm manipulability).

Callers compiled in other files embed this code in their own cache entries;
:func:`kcl.jit.njit` drops those entries when this file is newer.
"""

from __future__ import annotations

import numpy as np

from kcl.jit import njit

EPS = 2.220446049250313e-16


@njit
def matvec_into(M: np.ndarray, x: np.ndarray, rows: int, inner: int, out: np.ndarray) -> None:
    """``out[:rows] = M[:rows, :inner] x[:inner]``."""
    for i in range(rows):
        t = 0.0
        for c in range(inner):
            t += M[i, c] * x[c]
        out[i] = t


@njit
def mul_abt_into(A: np.ndarray, B: np.ndarray, rows: int, cols: int, inner: int, out: np.ndarray, row0: int) -> None:
    """``out[row0:row0 + rows, :cols] = A[:rows, :inner] B[:cols, :inner]^T``."""
    for i in range(rows):
        for j in range(cols):
            t = 0.0
            for k in range(inner):
                t += A[i, k] * B[j, k]
            out[row0 + i, j] = t


@njit
def mul_sparse_into(A: np.ndarray, B: np.ndarray, rows: int, inner: int, cols: int, out: np.ndarray) -> None:
    """``out[:rows, :cols] = A[:rows, :inner] B[:inner, :cols]``, skipping A's zero
    entries (the projectors Q and the task Jacobians have many)."""
    for i in range(rows):
        for j in range(cols):
            out[i, j] = 0.0
        for k in range(inner):
            a = A[i, k]
            if a != 0.0:
                for j in range(cols):
                    out[i, j] += a * B[k, j]


@njit
def sym_cross_into(A: np.ndarray, ra: int, B: np.ndarray, rb: int, cols: int, out: np.ndarray) -> None:
    """``out[:cols, :cols] = A[:ra]^T A[:ra] + B[:rb]^T B[:rb]`` (both ``cols``
    columns wide): the lower triangle computed, mirrored to the upper."""
    for i in range(cols):
        for j in range(i + 1):
            t = 0.0
            for k in range(ra):
                t += A[k, i] * A[k, j]
            for k in range(rb):
                t += B[k, i] * B[k, j]
            out[i, j] = t
            out[j, i] = t


@njit
def tridiagonalize(A: np.ndarray, n: int, Q: np.ndarray, d: np.ndarray, e: np.ndarray) -> None:
    """Reduce the symmetric ``A[:n, :n]`` (overwritten) to tridiagonal form:
    ``A = Q^T T Q`` with T's diagonal in ``d[:n]`` and its sub-diagonal in
    ``e[:n-1]``; ``Q[:n, :n]`` orthogonal (stored transposed, so that the
    updates run along contiguous rows)."""
    for i in range(n):
        for j in range(n):
            Q[i, j] = 0.0
        Q[i, i] = 1.0
    v = np.empty(n)
    p = np.empty(n)
    for k in range(n - 2):
        # Householder vector v (unit) mapping A[k+1:, k] onto a multiple of e_1
        tail = 0.0  # squared norm of A[k+2:, k] (summed apart: no cancellation)
        for i in range(k + 2, n):
            tail += A[i, k] * A[i, k]
        if tail == 0.0:  # already tridiagonal in this column
            continue
        x0 = A[k + 1, k]
        norm = np.sqrt(x0 * x0 + tail)
        alpha = -norm if x0 >= 0.0 else norm
        v[k + 1] = x0 - alpha
        vv = v[k + 1] * v[k + 1]
        for i in range(k + 2, n):
            v[i] = A[i, k]
            vv += v[i] * v[i]
        inv = 1.0 / np.sqrt(vv)
        for i in range(k + 1, n):
            v[i] *= inv
        # A22 <- H A22 H with H = I - 2 v v^T:  A22 - v w^T - w v^T,
        # p = A22 v, w = 2 p - 2 (v.p) v
        vp = 0.0
        for i in range(k + 1, n):
            t = 0.0
            for j in range(k + 1, n):
                t += A[i, j] * v[j]
            p[i] = t
            vp += v[i] * t
        for i in range(k + 1, n):
            p[i] = 2.0 * p[i] - 2.0 * vp * v[i]  # w
        for i in range(k + 1, n):
            for j in range(k + 1, i + 1):
                t = A[i, j] - v[i] * p[j] - p[i] * v[j]
                A[i, j] = t
                A[j, i] = t
        A[k + 1, k] = alpha
        A[k, k + 1] = alpha
        for i in range(k + 2, n):
            A[i, k] = 0.0
            A[k, i] = 0.0
        # Q <- Q H, stored transposed (Q^T <- H Q^T): rows k+1.. of Q^T
        for i in range(n):
            p[i] = 0.0
        for j in range(k + 1, n):
            vj = v[j]
            for i in range(n):
                p[i] += Q[j, i] * vj
        for j in range(k + 1, n):
            vj = 2.0 * v[j]
            for i in range(n):
                Q[j, i] -= vj * p[i]
    for i in range(n):
        d[i] = A[i, i]
    for i in range(n - 1):
        e[i] = A[i + 1, i]


@njit
def tridiagonal_qr(n: int, d: np.ndarray, e: np.ndarray, Q: np.ndarray) -> bool:
    """Diagonalize the symmetric tridiagonal (d, e) in place by implicit QR
    steps with Wilkinson shifts, accumulating the rotations into the rows of
    ``Q[:n, :]`` (the transposed eigenvector matrix of :func:`tridiagonalize`).
    On return ``d`` holds the eigenvalues and row i of Q the eigenvector of
    ``d[i]``. False if it did not converge."""
    rows = Q.shape[1]
    hi = n - 1
    steps = 0
    while hi > 0:
        # deflate negligible couplings
        for i in range(hi):
            if abs(e[i]) <= EPS * (abs(d[i]) + abs(d[i + 1])):
                e[i] = 0.0
        while hi > 0 and e[hi - 1] == 0.0:
            hi -= 1
        if hi == 0:
            break
        lo = hi - 1
        while lo > 0 and e[lo - 1] != 0.0:
            lo -= 1
        steps += 1
        if steps > 30 * n:
            return False
        # Wilkinson shift from the trailing 2 x 2 block
        dd = 0.5 * (d[hi - 1] - d[hi])
        b = e[hi - 1]
        root = np.sqrt(dd * dd + b * b)
        mu = d[hi] - b * b / (dd + (root if dd >= 0.0 else -root))
        x = d[lo] - mu
        z = e[lo]
        for k in range(lo, hi):
            r = np.sqrt(x * x + z * z)
            if r == 0.0:
                c, s = 1.0, 0.0
            else:
                c, s = x / r, -z / r
            if k > lo:
                e[k - 1] = r
            a0, b0, c0 = d[k], e[k], d[k + 1]
            cs = c * s
            d[k] = c * c * a0 - 2.0 * cs * b0 + s * s * c0
            d[k + 1] = s * s * a0 + 2.0 * cs * b0 + c * c * c0
            e[k] = cs * (a0 - c0) + (c * c - s * s) * b0
            if k < hi - 1:
                x = e[k]
                z = -s * e[k + 1]
                e[k + 1] = c * e[k + 1]
            for i in range(rows):
                qk = Q[k, i]
                q1 = Q[k + 1, i]
                Q[k, i] = c * qk - s * q1
                Q[k + 1, i] = s * qk + c * q1
    return True


@njit
def sym_eig(M: np.ndarray) -> tuple[bool, np.ndarray, np.ndarray]:
    """``(ok, s, V)`` with ``M = V diag(s) V^T`` for a symmetric M (only its
    values are read, M is not modified); ``ok`` False: no convergence (then
    s and V are meaningless, use ``numpy.linalg.eigh``). V is Fortran-ordered
    (a transposed view), like numpy.linalg.eigh's under Numba."""
    n = M.shape[0]
    A = np.empty((n, n))
    for i in range(n):
        for j in range(n):
            A[i, j] = M[i, j]
    Vt = np.empty((n, n))  # row i: eigenvector i
    s = np.empty(n)
    e = np.zeros(max(n - 1, 1))
    if n == 1:
        Vt[0, 0] = 1.0
        s[0] = A[0, 0]
        return True, s, Vt.T
    tridiagonalize(A, n, Vt, s, e)
    ok = tridiagonal_qr(n, s, e, Vt)
    return ok, s, Vt.T


@njit
def cholesky_above(M: np.ndarray, d: int, shift: float, L: np.ndarray) -> bool:
    """Cholesky factor ``L`` (lower, first d x d block) of ``M[:d, :d] - shift I``.

    Returns False (L partly written) when that matrix is not positive definite,
    i.e. when some eigenvalue of ``M[:d, :d]`` is <= ``shift``.
    """
    for j in range(d):
        s = M[j, j] - shift
        for k in range(j):
            s -= L[j, k] * L[j, k]
        if not s > 0.0:  # also catches NaN
            return False
        ljj = np.sqrt(s)
        L[j, j] = ljj
        for i in range(j + 1, d):
            t = M[i, j]
            for k in range(j):
                t -= L[i, k] * L[j, k]
            L[i, j] = t / ljj
    return True


@njit
def cholesky_solve(L: np.ndarray, d: int, b: np.ndarray) -> None:
    """Solve ``L L^T x = b`` in place (b: first d entries)."""
    for i in range(d):
        t = b[i]
        for k in range(i):
            t -= L[i, k] * b[k]
        b[i] = t / L[i, i]
    for i in range(d - 1, -1, -1):
        t = b[i]
        for k in range(i + 1, d):
            t -= L[k, i] * b[k]
        b[i] = t / L[i, i]


@njit
def well_conditioned_factor(M: np.ndarray, d: int, th: float, L: np.ndarray) -> bool:
    """Cholesky factor of ``M[:d, :d]`` when all its eigenvalues exceed ``th``.

    Then RegPinv(M) = M^-1 exactly (every gain is 1/s), so a solve with ``L``
    replaces the eigendecomposition. Returns False otherwise (caller falls
    back to the eigendecomposition, which handles the regularized region).
    """
    if not cholesky_above(M, d, th, L):
        return False
    return cholesky_above(M, d, 0.0, L)


@njit
def extend_basis(St: np.ndarray, d: int, V: np.ndarray, m: int) -> int:
    """Extend the orthonormal basis held in the rows ``St[:d]`` with the span
    of the rows ``V[:m]``; returns the new dimension (<= n).

    Modified Gram-Schmidt, two passes. A vector whose residual is below 1e-12
    of its norm is dependent on the basis and dropped (structural
    dependencies, e.g. more rows than DOFs, leave ~1e-16). Nearly dependent
    vectors are kept: they give the restricted matrix a small eigenvalue, the
    Cholesky test then fails and the caller uses the eigendecomposition.
    """
    n = St.shape[1]
    for j in range(m):
        if d == n:
            break
        norm0 = 0.0
        for i in range(n):
            St[d, i] = V[j, i]
            norm0 += V[j, i] * V[j, i]
        if norm0 == 0.0:
            continue
        norm0 = np.sqrt(norm0)
        for _ in range(2):
            for k in range(d):
                c = 0.0
                for i in range(n):
                    c += St[k, i] * St[d, i]
                for i in range(n):
                    St[d, i] -= c * St[k, i]
        norm = 0.0
        for i in range(n):
            norm += St[d, i] * St[d, i]
        norm = np.sqrt(norm)
        if norm <= 1e-12 * norm0:
            continue
        for i in range(n):
            St[d, i] /= norm
        d += 1
    return d


@njit
def gram_sqrt_det(J: np.ndarray) -> float:
    """``sqrt(det(J J^T))`` (rows <= columns) or ``sqrt(det(J^T J))`` of a small
    matrix by Cholesky; 0.0 when the Gram matrix is (numerically) singular.
    Used for the arm manipulability (kcl.model)."""
    r, c = J.shape
    d = r if r <= c else c
    G = np.empty((d, d))
    for i in range(d):
        for j in range(i + 1):
            t = 0.0
            if r <= c:
                for k in range(c):
                    t += J[i, k] * J[j, k]
            else:
                for k in range(r):
                    t += J[k, i] * J[k, j]
            G[i, j] = t
            G[j, i] = t
    L = np.empty((d, d))
    if not cholesky_above(G, d, 0.0, L):
        return 0.0
    out = 1.0
    for i in range(d):
        out *= L[i, i]
    return out
