"""The compiled TPIK recursion (MARIS eq. 11-12, ../shared/spec/icat.md): the
one solver of the KCL, behind :func:`kcl.icat.tpik` and the controller's cycle
(:mod:`kcl.cycle`).

Inputs are flat: the levels' rows stacked (``J_rows`` (M x n), ``a_rows``,
``xdot_rows``) with ``offsets`` (L + 1) marking where level k's rows start.
:func:`solve` does not validate; callers run :func:`check_stack` first.

The algebra, exact rearrangements of the spec's formulas:

* Rows with zero activation are dropped (they add nothing to any term); a
  level whose activations are all zero is skipped.
* ``P_k = X^{#,A,I}`` comes from the small m x m Gram matrix ``B B^T`` with
  ``B = sqrt(A) X`` (the same non-zero spectrum as ``X^T A X``), in closed form
  when m = 1.
* ``W_k`` is never formed: only ``W_k (xdot_k - J_k rho)`` is needed, from the
  matrix ``X^T A X + eta (I-Q)^T (I-Q) = Z^T Z`` with ``Z = [B; sqrt(eta) (I-Q)]``
  (``I - Q`` is updated alongside Q). For the first executed level Q = I and
  W = X P.
* RegPinv of a symmetric positive semi-definite matrix uses its symmetric
  eigendecomposition (the same as the SVD for such matrices), and is the plain
  inverse, by Cholesky, whenever every eigenvalue exceeds the threshold.
* ``I - Q`` is a sum of ``QP_j X_j``, so ``Z^T Z`` has its range in the span of
  the rows of the levels run so far: while that span is smaller than n the
  weighted problem is solved on an orthonormal basis of it (Gram-Schmidt).
* A level whose ``||sqrt(A) X||_F^2`` is below 1e-8 has every eigenvalue at or
  below the zero threshold, so P = 0: it is skipped (typically the final
  minimum-velocity level once the stack takes every DOF). Q is not updated
  after the last level.

The small dense linear algebra (eigendecomposition, Cholesky, Gram-Schmidt) is
in :mod:`kcl.small_linalg`; :mod:`tests.kcl.oracle` holds the plain
transcription of the spec that the tests compare this with.
"""

from __future__ import annotations

import numpy as np

from kcl.buffers import take, take2
from kcl.jit import njit
from kcl.small_linalg import (
    cholesky_solve,
    extend_basis,
    matvec_into,
    mul_abt_into,
    mul_sparse_into,
    sym_cross_into,
    sym_eig,
    well_conditioned_factor,
)

__all__ = ["BUDGET_FLOOR", "ZERO_SINGULAR_VALUE", "check_stack", "solve"]

#: singular values at or below this are treated as zero by RegPinv (icat.md)
ZERO_SINGULAR_VALUE = 1e-8
#: a level's saturation budget never shrinks below this fraction of the limit (icat.md)
BUDGET_FLOOR = 0.1
#: A level whose ||sqrt(A) X||_F^2 is below this has all its eigenvalues at or
#: below ZERO_SINGULAR_VALUE (margin for rounding): it changes nothing.
NEGLIGIBLE_TRACE = ZERO_SINGULAR_VALUE * (1.0 - 1e-6)


@njit
def gain(v: float, lam: float, th: float) -> float:
    """Singular value of RegPinv(M) for one eigenvalue ``v`` of M."""
    if v > th:
        return 1.0 / v
    if v > ZERO_SINGULAR_VALUE:
        return v / (v * v + lam * (0.5 * np.cos(np.pi * v / th) + 0.5))
    return 0.0


@njit
def gains(s: np.ndarray, lam: float, th: float) -> np.ndarray:
    """Singular values of RegPinv(M) from those (eigenvalues) of M."""
    out = np.empty(s.shape[0])
    for i in range(s.shape[0]):
        out[i] = gain(s[i], lam, th)
    return out


@njit
def eig(M: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Eigenvalues and eigenvectors (columns) of the small symmetric ``M``:
    :func:`kcl.small_linalg.sym_eig`, or LAPACK if that did not converge."""
    ok, s, V = sym_eig(M)
    if ok:
        return s, V
    return np.linalg.eigh(M)


@njit
def regpinv_apply(
    Mw: np.ndarray,
    C: np.ndarray,
    m: int,
    d: int,
    w: np.ndarray,
    lam: float,
    th: float,
    L: np.ndarray,
    y: np.ndarray,
    out: np.ndarray,
) -> None:
    """``out[:m] = C RegPinv(Mw[:d, :d]) C^T w`` (C: m x d, only that block is
    read): by Cholesky when every eigenvalue of Mw exceeds ``th`` (then
    RegPinv is the inverse), else by the eigendecomposition. ``y``: (>= d,)
    workspace."""
    for j in range(d):  # y = C^T w
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
    matvec_into(C, y, m, d, out)


@njit
def weighted_solve_subspace(
    B: np.ndarray,
    X: np.ndarray,
    m: int,
    IQ: np.ndarray,
    w: np.ndarray,
    St: np.ndarray,
    d: int,
    lam: float,
    th: float,
    L: np.ndarray,
    ZS: np.ndarray,
    Ms: np.ndarray,
    C: np.ndarray,
    y: np.ndarray,
    out: np.ndarray,
) -> None:
    """``out[:m] = X RegPinv(Z^T Z) X^T w`` with ``Z = [B; IQ]`` (B, X: first
    m rows), the range of ``Z^T Z`` lying in the span of the d orthonormal
    rows of ``St``: computed on that span (d x d problem; the other
    eigenvalues are zero and get gain 0). ZS, Ms, C, y: workspaces."""
    n = B.shape[1]
    mul_abt_into(B, St, m, d, n, ZS, 0)  # ZS = Z S (S: the basis St^T)
    mul_abt_into(IQ, St, n, d, n, ZS, m)
    sym_cross_into(ZS, m, ZS[m:], n, d, Ms)  # (Z S)^T (Z S)
    mul_abt_into(X, St, m, d, n, C, 0)  # C = X S
    regpinv_apply(Ms, C, m, d, w, lam, th, L, y, out)


@njit
def weighted_solve_full(
    B: np.ndarray,
    X: np.ndarray,
    m: int,
    IQ: np.ndarray,
    w: np.ndarray,
    lam: float,
    th: float,
    L: np.ndarray,
    Mw: np.ndarray,
    y: np.ndarray,
    out: np.ndarray,
) -> None:
    """:func:`weighted_solve_subspace` with S = I (the whole space): the
    matrix is ``B^T B + IQ^T IQ`` itself and ``C = X``."""
    n = B.shape[1]
    sym_cross_into(B, m, IQ, n, n, Mw)
    regpinv_apply(Mw, X, m, n, w, lam, th, L, y, out)


@njit
def solve(
    J_rows: np.ndarray,
    a_rows: np.ndarray,
    xdot_rows: np.ndarray,
    offsets: np.ndarray,
    lams: np.ndarray,
    ths: np.ndarray,
    min_velocity: bool,
    lam_mv: float,
    th_mv: float,
    eta: float,
    limits: np.ndarray,
    has_limits: bool,
    raw: np.ndarray,
    applied: np.ndarray,
    factors: np.ndarray,
) -> tuple[np.ndarray, float]:
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
    # every work array is a view of ONE buffer (one allocation per call)
    ws = np.empty(5 * n * n + 6 * mmax * n + 8 * mmax + mmax * mmax + 5 * n + (mmax + n) * n)
    Q, o = take2(ws, 0, n, n)
    IQ, o = take2(ws, o, n, n)  # sqrt(eta) (I - Q)
    upper, o = take(ws, o, n)
    lower, o = take(ws, o, n)
    # rows St[:d_done]: orthonormal basis of the span of the rows of the levels
    # executed so far (range of I - Q), kept while it is smaller than n
    St, o = take2(ws, o, n, n)
    L, o = take2(ws, o, n, n)  # Cholesky workspace
    # per-level buffers (level k uses their first m rows / columns)
    Jb, o = take2(ws, o, mmax, n)
    Xb, o = take2(ws, o, mmax, n)
    Bb, o = take2(ws, o, mmax, n)
    ab, o = take(ws, o, mmax)
    xb, o = take(ws, o, mmax)
    rb, o = take(ws, o, mmax)
    sa, o = take(ws, o, mmax)
    a15, o = take(ws, o, mmax)
    wb, o = take(ws, o, mmax)
    wr, o = take(ws, o, mmax)
    eb, o = take(ws, o, mmax)
    G, o = take2(ws, o, mmax, mmax)
    P, o = take2(ws, o, n, mmax)
    QPb, o = take2(ws, o, n, mmax)
    Pr, o = take(ws, o, n)
    delta, o = take(ws, o, n)
    ZS, o = take2(ws, o, mmax + n, n)
    Mw, o = take2(ws, o, n, n)
    C, o = take2(ws, o, mmax, n)
    yb, o = take(ws, o, n)
    for i in range(n):
        for j in range(n):
            Q[i, j] = 0.0
            IQ[i, j] = 0.0
        Q[i, i] = 1.0
        upper[i] = limits[i]
        lower[i] = -limits[i]
    rho = np.zeros(n)
    root_eta = np.sqrt(eta)
    first = True  # Q is exactly I and rho exactly 0
    d_done = 0
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
                mul_sparse_into(Jb, Q, m, n, n, X)
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
            matvec_into(P, r, n, m, Pr)  # W = X P when Q = I: wr = X (P r)
            matvec_into(X, Pr, m, n, wr)
        else:
            QP = QPb
            mul_sparse_into(Q, P, n, n, m, QP)
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
        matvec_into(QP, wr, n, m, delta)
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


@njit
def check_stack(J_rows: np.ndarray, a_rows: np.ndarray, xdot_rows: np.ndarray, offsets: np.ndarray) -> tuple[int, int]:
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
