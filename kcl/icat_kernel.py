"""Compiled (Numba) TPIK recursion used by :func:`kcl.icat.tpik`.

Same algebra as the numpy path in :mod:`kcl.icat` (see its module docstring:
Gram-matrix pseudo-inverse for ``P``, only ``W r`` for ``W``, dropped zero
rows, ``Z^T Z`` for the weighted matrix), but the whole pass runs in one
compiled call, so the ~25 numpy calls per level (about 1 us each on the
target machines) disappear. The small symmetric eigenproblems are solved by
:func:`kcl.small_linalg.sym_eig` (Householder + implicit QR, ~8 us for a
13 x 13 one here) instead of ``numpy.linalg.eigh`` (LAPACK behind Numba's
wrapper: workspace query, allocation, copy and NaN check on every call,
20-30 us for 13 x 13 on the same machine).

One more saving: ``I - Q`` is a sum of ``QP_j X_j``, so the weighted matrix
``X^T A X + eta (I-Q)^T (I-Q)`` has its range in the span of the current and
earlier levels' rows. While that span has dimension d < n (fewer rows so far
than DOFs, or dependent ones), the weighted problem is solved in an
orthonormal basis of it (Gram-Schmidt, then d x d) instead of n x n; the
remaining eigenvalues are zero and get gain 0, as in the reference.

Inputs are flat: the levels' rows stacked (``J_rows`` (M x n), ``a_rows``,
``xdot_rows``) with ``offsets`` (L + 1) marking where level k's rows start.
Nothing in :func:`solve` validates: :func:`kcl.icat.tpik` does it before
calling, :func:`kcl.icat_stacked.solve_stacked` calls :func:`check_stack` first.

Fast paths (exact, not approximations): RegPinv(M) equals M^-1 whenever every
eigenvalue of M exceeds the threshold (all gains are then 1/s). That is
tested with a Cholesky factorization of ``M - th I`` (a few hundred flops for
these sizes); when it succeeds, the P Gram matrix and the weighted matrix
(restricted to the span of the rows seen so far) are solved with Cholesky
instead of an eigendecomposition. When it fails (eigenvalues in the
regularized region, rank deficiency, the final minimum-velocity level near
full constraint) the eigendecomposition of the same matrix is used. A level
whose ``||sqrt(A) X||_F^2`` is below 1e-8 has every eigenvalue at or below the
zero threshold, so P = 0: it is skipped (typically the final minimum-velocity
level once the stack takes every DOF). Small products are explicit loops (no
BLAS call overhead), and the per-level arrays live in buffers allocated once
per call.

:func:`check_stack` validates a flat stack (used by
:func:`kcl.icat_stacked.solve_stacked`). The small dense linear algebra
(eigendecomposition, Cholesky, Gram-Schmidt) is in :mod:`kcl.small_linalg`.

Numba compiles these functions on first use and caches the machine code in
``__pycache__`` (``cache=True``): the first run on a machine pays the compile
(several seconds), later processes load it in well under a second. Importing
this module needs Numba; ``kcl.icat`` imports it lazily and falls back to its
numpy path (same results) when Numba is missing or ``MARIS_ICAT_NO_JIT=1``.
The cache of :func:`solve` embeds :mod:`kcl.small_linalg`'s code but Numba
keys it on this file only: :func:`kcl.jit_cache.drop_stale` discards it at
import when that module is newer.
"""

from __future__ import annotations

import numba
import numpy as np

from kcl import small_linalg
from kcl.jit_cache import KERNEL_OPTIONS, drop_stale
from kcl.small_linalg import cholesky_solve, extend_basis, gram_sqrt_det, sym_eig, well_conditioned_factor

drop_stale(__file__, [__file__, small_linalg.__file__])  # solve() embeds small_linalg's code

__all__ = ["solve", "check_stack", "gram_sqrt_det"]  # gram_sqrt_det: re-exported, it used to live here

ZERO_SINGULAR_VALUE = 1e-8  # same constants as kcl.icat
BUDGET_FLOOR = 0.1
#: A level whose ||sqrt(A) X||_F^2 is below this has all its eigenvalues at or
#: below ZERO_SINGULAR_VALUE (margin for rounding): it changes nothing.
NEGLIGIBLE_TRACE = ZERO_SINGULAR_VALUE * (1.0 - 1e-6)


@numba.njit(**KERNEL_OPTIONS)
def gain(v, lam, th):
    """Singular value of RegPinv(M) for one eigenvalue ``v`` of M."""
    if v > th:
        return 1.0 / v
    if v > ZERO_SINGULAR_VALUE:
        return v / (v * v + lam * (0.5 * np.cos(np.pi * v / th) + 0.5))
    return 0.0


@numba.njit(**KERNEL_OPTIONS)
def gains(s, lam, th):
    """Singular values of RegPinv(M) from those (eigenvalues) of M."""
    out = np.zeros(s.shape[0])
    for i in range(s.shape[0]):
        v = s[i]
        if v > th:
            out[i] = 1.0 / v
        elif v > ZERO_SINGULAR_VALUE:
            out[i] = v / (v * v + lam * (0.5 * np.cos(np.pi * v / th) + 0.5))
    return out


@numba.njit(**KERNEL_OPTIONS)
def eig(M):
    """Eigenvalues and eigenvectors (columns) of the small symmetric ``M``:
    :func:`kcl.small_linalg.sym_eig`, or LAPACK if that did not converge."""
    ok, s, V = sym_eig(M)
    if ok:
        return s, V
    return np.linalg.eigh(M)


@numba.njit(**KERNEL_OPTIONS)
def regpinv_apply(Mw, C, m, d, w, lam, th, L, y, out):
    """``out[:m] = C RegPinv(Mw[:d, :d]) C^T w`` (C: m x d, only that block is
    read): by Cholesky when every eigenvalue of Mw exceeds ``th`` (then
    RegPinv is the inverse), else by the eigendecomposition. ``y``: (>= d,)
    workspace."""
    for j in range(d):
        t = 0.0
        for i in range(m):
            t += C[i, j] * w[i]
        y[j] = t
    if well_conditioned_factor(Mw, d, th, L):
        cholesky_solve(L, d, y)
    else:
        s, V = eig(Mw[:d, :d])
        g = gains(s, lam, th)
        z = np.zeros(d)
        for k in range(d):
            t = 0.0
            for j in range(d):
                t += V[j, k] * y[j]
            t *= g[k]
            for j in range(d):
                z[j] += V[j, k] * t
        for j in range(d):
            y[j] = z[j]
    for i in range(m):
        t = 0.0
        for j in range(d):
            t += C[i, j] * y[j]
        out[i] = t


@numba.njit(**KERNEL_OPTIONS)
def weighted_solve_subspace(B, X, m, IQ, w, St, d, lam, th, L, ZS, Ms, C, y, out):
    """``out[:m] = X RegPinv(Z^T Z) X^T w`` with ``Z = [B; IQ]`` (B, X: first
    m rows), the range of ``Z^T Z`` lying in the span of the d orthonormal
    rows of ``St``: computed on that span (d x d problem; the other
    eigenvalues are zero and get gain 0). ZS, Ms, C, y: workspaces."""
    n = B.shape[1]
    for i in range(m):
        for j in range(d):
            t = 0.0
            for k in range(n):
                t += B[i, k] * St[j, k]
            ZS[i, j] = t
    for i in range(n):
        for j in range(d):
            t = 0.0
            for k in range(n):
                t += IQ[i, k] * St[j, k]
            ZS[m + i, j] = t
    for i in range(d):
        for j in range(i + 1):
            t = 0.0
            for k in range(m + n):
                t += ZS[k, i] * ZS[k, j]
            Ms[i, j] = t
            Ms[j, i] = t
    for i in range(m):  # C = X S
        for j in range(d):
            t = 0.0
            for k in range(n):
                t += X[i, k] * St[j, k]
            C[i, j] = t
    regpinv_apply(Ms, C, m, d, w, lam, th, L, y, out)


@numba.njit(**KERNEL_OPTIONS)
def weighted_solve_full(B, X, m, IQ, w, lam, th, L, Mw, y, out):
    """:func:`weighted_solve_subspace` with S = I (the whole space): the
    matrix is ``B^T B + IQ^T IQ`` itself and ``C = X``."""
    n = B.shape[1]
    for i in range(n):
        for j in range(i + 1):
            t = 0.0
            for k in range(m):
                t += B[k, i] * B[k, j]
            for k in range(n):
                t += IQ[k, i] * IQ[k, j]
            Mw[i, j] = t
            Mw[j, i] = t
    regpinv_apply(Mw, X, m, n, w, lam, th, L, y, out)


@numba.njit(**KERNEL_OPTIONS)
def solve(
    J_rows,
    a_rows,
    xdot_rows,
    offsets,
    lams,
    ths,
    min_velocity,
    lam_mv,
    th_mv,
    eta,
    limits,
    has_limits,
    raw,
    applied,
    factors,
):
    """Run the recursion; returns (ydot, final_scale).

    Fills ``raw``/``applied`` (levels x n) with each level's increment
    before/after saturation and ``factors`` with the saturation factor
    (-1 marks a skipped all-zero level). Every work array (per-level ones
    sized for the largest level) is a view of one buffer allocated once per
    call: two allocations per call (that buffer and the returned ``ydot``).
    """
    n = J_rows.shape[1]
    n_given = offsets.shape[0] - 1
    total = n_given + (1 if min_velocity else 0)
    mmax = n
    for k in range(n_given):
        mmax = max(mmax, offsets[k + 1] - offsets[k])
    # every work array is a view of ONE buffer (one allocation per call, not ~25)
    ws = np.empty(5 * n * n + 6 * mmax * n + 8 * mmax + mmax * mmax + 5 * n + (mmax + n) * n)
    o = 0
    Q = ws[o : o + n * n].reshape((n, n))
    o += n * n
    IQ = ws[o : o + n * n].reshape((n, n))  # sqrt(eta) (I - Q)
    o += n * n
    for i in range(n):
        for j in range(n):
            Q[i, j] = 0.0
            IQ[i, j] = 0.0
        Q[i, i] = 1.0
    rho = np.zeros(n)
    root_eta = np.sqrt(eta)
    upper = ws[o : o + n]
    o += n
    lower = ws[o : o + n]
    o += n
    for i in range(n):
        upper[i] = limits[i]
        lower[i] = -limits[i]
    first = True  # Q is exactly I and rho exactly 0
    # rows St[:d_done]: orthonormal basis of the span of the rows of the levels
    # executed so far (range of I - Q), kept while it is smaller than n
    St = ws[o : o + n * n].reshape((n, n))
    o += n * n
    d_done = 0
    L = ws[o : o + n * n].reshape((n, n))  # Cholesky workspace
    o += n * n
    # per-level buffers (level k uses their first m rows / columns)
    Jb = ws[o : o + mmax * n].reshape((mmax, n))
    o += mmax * n
    Xb = ws[o : o + mmax * n].reshape((mmax, n))
    o += mmax * n
    Bb = ws[o : o + mmax * n].reshape((mmax, n))
    o += mmax * n
    ab = ws[o : o + mmax]
    o += mmax
    xb = ws[o : o + mmax]
    o += mmax
    rb = ws[o : o + mmax]
    o += mmax
    sa = ws[o : o + mmax]
    o += mmax
    a15 = ws[o : o + mmax]
    o += mmax
    wb = ws[o : o + mmax]
    o += mmax
    wr = ws[o : o + mmax]
    o += mmax
    eb = ws[o : o + mmax]
    o += mmax
    G = ws[o : o + mmax * mmax].reshape((mmax, mmax))
    o += mmax * mmax
    P = ws[o : o + n * mmax].reshape((n, mmax))
    o += n * mmax
    QPb = ws[o : o + n * mmax].reshape((n, mmax))
    o += n * mmax
    Pr = ws[o : o + n]
    o += n
    delta = ws[o : o + n]
    o += n
    ZS = ws[o : o + (mmax + n) * n].reshape((mmax + n, n))
    o += (mmax + n) * n
    Mw = ws[o : o + n * n].reshape((n, n))
    o += n * n
    C = ws[o : o + mmax * n].reshape((mmax, n))
    o += mmax * n
    yb = ws[o : o + n]
    for k in range(total):
        if k < n_given:
            lo = offsets[k]
            hi = offsets[k + 1]
            lam = lams[k]
            th = ths[k]
            m = 0
            for i in range(lo, hi):
                if a_rows[i] > 0.0:
                    for j in range(n):
                        Jb[m, j] = J_rows[i, j]
                    ab[m] = a_rows[i]
                    xb[m] = xdot_rows[i]
                    m += 1
            if m == 0:  # all-zero level: changes nothing
                factors[k] = -1.0
                continue
        else:  # the minimum-velocity level: J = I, a = 1, xdot = 0
            lam = lam_mv
            th = th_mv
            m = n
            for i in range(n):
                for j in range(n):
                    Jb[i, j] = 0.0
                Jb[i, i] = 1.0
                ab[i] = 1.0
                xb[i] = 0.0
        # X = J Q, r = xdot - J rho (Q = I, rho = 0 on the first level)
        if first:
            X = Jb
            r = xb
        else:
            X = Xb
            r = rb
            if k >= n_given:
                for i in range(n):
                    r[i] = -rho[i]
                    for j in range(n):
                        X[i, j] = Q[i, j]
            else:
                for i in range(m):
                    t = xb[i]
                    for j in range(n):
                        t -= Jb[i, j] * rho[j]
                    r[i] = t
                    for j in range(n):
                        X[i, j] = 0.0
                    for kk in range(n):
                        jik = Jb[i, kk]
                        if jik != 0.0:
                            for j in range(n):
                                X[i, j] += jik * Q[kk, j]
        for i in range(m):
            sa[i] = np.sqrt(ab[i])
            a15[i] = ab[i] * sa[i]
        B = Bb
        bb = 0.0
        for i in range(m):
            for j in range(n):
                v = X[i, j] * sa[i]
                B[i, j] = v
                bb += v * v
        if bb < NEGLIGIBLE_TRACE:
            # every eigenvalue of X^T A X is <= its trace ||B||_F^2 <= 1e-8:
            # all gains are 0, so P = 0: no increment and Q unchanged
            # (typically the minimum-velocity level once every DOF is taken)
            for i in range(n):
                raw[k, i] = 0.0
                applied[k, i] = 0.0
            factors[k] = 1.0
            continue
        # P = RegPinv(X^T A X) X^T A A  (n x m, first m columns of the buffer)
        if m == 1:
            g = gain(bb, lam, th) * ab[0] * ab[0]
            for j in range(n):
                P[j, 0] = X[0, j] * g
        elif m <= n:
            for i in range(m):  # Gram B B^T
                for j in range(i + 1):
                    t = 0.0
                    for kk in range(n):
                        t += B[i, kk] * B[j, kk]
                    G[i, j] = t
                    G[j, i] = t
            if well_conditioned_factor(G, m, th, L):
                # P = B^T G^-1 diag(a^1.5)
                for c in range(m):
                    for i in range(m):
                        eb[i] = 0.0
                    eb[c] = a15[c]
                    cholesky_solve(L, m, eb)
                    for j in range(n):
                        t = 0.0
                        for i in range(m):
                            t += B[i, j] * eb[i]
                        P[j, c] = t
            else:
                s, U = eig(G[:m, :m])
                P[:, :m] = (B[:m].T @ (U * gains(s, lam, th))) @ (U.T * a15[:m])
        else:
            s, V = eig(B[:m].T @ B[:m])
            BV = B[:m] @ V
            for i in range(m):
                BV[i, :] *= a15[i]
            P[:, :m] = (V * gains(s, lam, th)) @ BV.T
        if first:
            QP = P
            for j in range(n):  # W = X P when Q = I: wr = X (P r)
                t = 0.0
                for c in range(m):
                    t += P[j, c] * r[c]
                Pr[j] = t
            for i in range(m):
                t = 0.0
                for j in range(n):
                    t += X[i, j] * Pr[j]
                wr[i] = t
        else:
            QP = QPb
            for i in range(n):
                for j in range(m):
                    QP[i, j] = 0.0
                for kk in range(n):
                    q = Q[i, kk]
                    if q != 0.0:
                        for j in range(m):
                            QP[i, j] += q * P[kk, j]
            for i in range(m):
                wb[i] = ab[i] * ab[i] * r[i]
            # range(Z^T Z) lies in the span of B's rows (those of X) and of the
            # earlier levels' (I - Q is a sum of QP_j X_j): solve on an
            # orthonormal basis of that span when it is smaller than n
            d = d_done
            if d < n:
                d = extend_basis(St, d, B, m)
            if d < n:
                weighted_solve_subspace(B, X, m, IQ, wb, St, d, lam, th, L, ZS, Mw, C, yb, wr)
            else:
                weighted_solve_full(B, X, m, IQ, wb, lam, th, L, Mw, yb, wr)
            d_done = d
        for i in range(n):  # delta = QP wr
            t = 0.0
            for c in range(m):
                t += QP[i, c] * wr[c]
            delta[i] = t
        if k != total - 1:
            for i in range(n):
                for j in range(n):
                    t = 0.0
                    for c in range(m):
                        t += QP[i, c] * X[c, j]
                    Q[i, j] -= t
                    IQ[i, j] += root_eta * t
            if first and d_done < n:  # (the weighted step extends it on later levels)
                d_done = extend_basis(St, d_done, B, m)
        for i in range(n):
            raw[k, i] = delta[i]
        factor = 1.0
        if has_limits:
            for i in range(n):
                step = delta[i]
                if step > upper[i]:
                    factor = min(factor, upper[i] / step)
                elif step < lower[i]:
                    factor = min(factor, lower[i] / step)
            if factor < 1.0:
                for i in range(n):
                    delta[i] *= factor
            for i in range(n):
                f = BUDGET_FLOOR * limits[i]
                upper[i] = max(upper[i] - delta[i], f)
                lower[i] = min(lower[i] - delta[i], -f)
        for i in range(n):
            applied[k, i] = delta[i]
            rho[i] += delta[i]
        factors[k] = factor
        first = False
    final = 1.0
    if has_limits:
        for i in range(n):
            v = abs(rho[i])
            if v > limits[i]:
                final = min(final, limits[i] / v)
        if final < 1.0:
            rho *= final
    return rho, final


@numba.njit(**KERNEL_OPTIONS)
def check_stack(J_rows, a_rows, xdot_rows, offsets):
    """First bad level of a flat stack: ``(level, code)``, ``(-1, 0)`` if all fine.

    code 1: J has NaN/inf, 2: a has NaN/inf, 3: xdot has NaN/inf,
    4: an activation outside [0, 1].
    """
    n = J_rows.shape[1]
    for k in range(offsets.shape[0] - 1):
        for i in range(offsets[k], offsets[k + 1]):
            for j in range(n):
                if not np.isfinite(J_rows[i, j]):
                    return k, 1
            if not np.isfinite(a_rows[i]):
                return k, 2
            if not np.isfinite(xdot_rows[i]):
                return k, 3
            if a_rows[i] < 0.0 or a_rows[i] > 1.0:
                return k, 4
    return -1, 0
