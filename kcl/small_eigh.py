"""Eigendecomposition of small symmetric matrices, compiled (Numba).

The TPIK kernel (:mod:`kcl.icat_kernel`) needs ``M = V diag(s) V^T`` of
symmetric matrices of size 1 to ~13 whenever a regularized pseudo-inverse
falls in the regularized region. ``numpy.linalg.eigh`` inside Numba calls
LAPACK through a wrapper that queries and allocates its workspace, copies the
matrix to Fortran order and checks it for NaN on every call: 8-30 us for
7 x 7 to 13 x 13 here, most of it overhead. :func:`sym_eig` does the textbook
algorithm in one compiled loop nest instead:

1. Householder reduction to tridiagonal form ``M = Q T Q^T`` (Q accumulated);
2. implicit symmetric QR steps with Wilkinson shifts on T (Givens rotations,
   bulge chasing, deflation when an off-diagonal entry falls below
   ``eps (|d_i| + |d_{i+1}|)``), rotations accumulated into Q.

Backward stable like LAPACK's ``dsyev``: the computed pairs are exact for a
matrix within a few ``eps ||M||`` of M. Eigenvalues come out in no particular
order (the callers apply a function elementwise; order is irrelevant).
When the QR iteration does not converge within ``30 n`` steps (never seen;
a guard against pathological input such as NaN), it returns False and the
caller uses ``numpy.linalg.eigh``.

Numba caveat: callers compiled with ``cache=True`` in other files embed this
code in their own cache entry, which Numba keys on THEIR file only;
:mod:`kcl.icat_kernel` drops its cache when this file is newer
(:func:`kcl.jit_cache.drop_stale`).
"""

from __future__ import annotations

import numba
import numpy as np

EPS = 2.220446049250313e-16


@numba.njit(cache=True, nogil=True)
def tridiagonalize(A, n, Q, d, e):
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


@numba.njit(cache=True, nogil=True)
def tridiagonal_qr(n, d, e, Q):
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


@numba.njit(cache=True, nogil=True)
def sym_eig(M):
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
