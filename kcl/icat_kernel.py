"""Compiled (Numba) TPIK recursion used by :func:`kcl.icat.tpik`.

Same algebra as the numpy path in :mod:`kcl.icat` (see its module docstring:
Gram-matrix pseudo-inverse for ``P``, only ``W r`` for ``W``, dropped zero
rows, ``Z^T Z`` for the weighted matrix), but the whole pass runs in one
compiled call, so the ~25 numpy calls per level (about 1 us each on the
target machines) disappear and what remains is mostly LAPACK's own work on
the small symmetric eigenproblems (~13 us for a 13 x 13 one).

One more saving: ``I - Q`` is a sum of ``QP_j X_j``, so the weighted matrix
``X^T A X + eta (I-Q)^T (I-Q)`` has its range in the span of the current and
earlier levels' rows. While that span has dimension d <= n - 4, the
eigenproblem is solved in an orthonormal basis of it (QR, then d x d) instead
of n x n; the remaining eigenvalues are zero and get gain 0, as in the
reference.

Inputs are flat: the levels' rows stacked (``J_rows`` (M x n), ``a_rows``,
``xdot_rows``) with ``offsets`` (L + 1) marking where level k's rows start.
Nothing here validates: :func:`kcl.icat.tpik` does it before calling.

Numba compiles these functions on first use and caches the machine code in
``__pycache__`` (``cache=True``): the first run on a machine pays the compile
(several seconds), later processes load it in well under a second. Importing
this module needs Numba; ``kcl.icat`` imports it lazily and falls back to its
numpy path (same results) when Numba is missing or ``MARIS_ICAT_NO_JIT=1``.
"""

from __future__ import annotations

import numba
import numpy as np

ZERO_SINGULAR_VALUE = 1e-8  # same constants as kcl.icat
BUDGET_FLOOR = 0.1
#: The weighted eigenproblem is solved in the d-dimensional span of the rows
#: seen so far when d <= n - SUBSPACE_MARGIN (smaller LAPACK problems).
SUBSPACE_MARGIN = 4


@numba.njit(cache=True, nogil=True)
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


@numba.njit(cache=True, nogil=True)
def solve(J_rows, a_rows, xdot_rows, offsets, lams, ths, min_velocity, lam_mv, th_mv,
          eta, limits, has_limits, raw, applied, factors):
    """Run the recursion; returns (ydot, final_scale).

    Fills ``raw``/``applied`` (levels x n) with each level's increment
    before/after saturation and ``factors`` with the saturation factor
    (-1 marks a skipped all-zero level).
    """
    n = J_rows.shape[1]
    n_given = offsets.shape[0] - 1
    total = n_given + (1 if min_velocity else 0)
    Q = np.eye(n)
    rho = np.zeros(n)
    IQ = np.zeros((n, n))  # sqrt(eta) (I - Q)
    root_eta = np.sqrt(eta)
    upper = limits.copy()
    lower = -limits
    first = True  # Q is exactly I and rho exactly 0
    rows = np.empty((n, n))  # X rows of the executed levels while they fit
    n_rows = 0
    tracking = True
    for k in range(total):
        if k < n_given:
            lo = offsets[k]
            hi = offsets[k + 1]
            lam = lams[k]
            th = ths[k]
            m = 0
            for i in range(lo, hi):
                if a_rows[i] > 0.0:
                    m += 1
            if m == 0:  # all-zero level: changes nothing
                factors[k] = -1.0
                continue
            J = np.empty((m, n))
            a = np.empty(m)
            xd = np.empty(m)
            c = 0
            for i in range(lo, hi):
                if a_rows[i] > 0.0:
                    J[c, :] = J_rows[i, :]
                    a[c] = a_rows[i]
                    xd[c] = xdot_rows[i]
                    c += 1
        else:  # the minimum-velocity level: J = I, a = 1, xdot = 0
            lam = lam_mv
            th = th_mv
            m = n
            J = np.eye(n)
            a = np.ones(n)
            xd = np.zeros(n)
        if first:
            X = J
            r = xd
        else:
            X = J @ Q
            r = xd - J @ rho
        sa = np.sqrt(a)
        a15 = a * sa
        B = np.empty((m, n))
        for i in range(m):
            B[i, :] = X[i, :] * sa[i]
        # P = RegPinv(X^T A X) X^T A A  (n x m)
        if m == 1:
            g = gains(np.array([B[0, :] @ B[0, :]]), lam, th)[0]
            P = np.empty((n, 1))
            P[:, 0] = X[0, :] * (g * a[0] * a[0])
        elif m <= n:
            s, U = np.linalg.eigh(B @ B.T)
            P = (B.T @ (U * gains(s, lam, th))) @ (U.T * a15)
        else:
            s, V = np.linalg.eigh(B.T @ B)
            BV = B @ V
            for i in range(m):
                BV[i, :] *= a15[i]
            P = (V * gains(s, lam, th)) @ BV.T
        if first:
            QP = P
            wr = X @ (P @ r)  # W = X P when Q = I
        else:
            QP = Q @ P
            Z = np.empty((m + n, n))
            Z[:m, :] = B
            Z[m:, :] = IQ
            Mw = Z.T @ Z
            dim = m + n_rows
            if tracking and dim <= n - SUBSPACE_MARGIN:
                # range(Mw) lies in the span of B's rows and of the earlier
                # levels' X rows (I - Q is a sum of QP_j X_j): solve the
                # d x d eigenproblem in an orthonormal basis S of that span;
                # the other n - d eigenvalues are zero (gain 0).
                Y = np.empty((n, dim))
                Y[:, :m] = B.T
                Y[:, m:] = rows[:n_rows, :].T
                S_any, _ = np.linalg.qr(Y)
                S = np.ascontiguousarray(S_any)
                St = np.ascontiguousarray(S.T)
                sw, E = np.linalg.eigh(St @ (Mw @ S))
                V = S @ np.ascontiguousarray(E)
            else:
                sw, V_f = np.linalg.eigh(Mw)
                V = np.ascontiguousarray(V_f)
            C = X @ V
            wr = C @ (gains(sw, lam, th) * ((a * a * r) @ C))
        delta = QP @ wr
        if k != total - 1:
            D = QP @ X
            Q -= D
            IQ += root_eta * D
            if tracking and n_rows + m <= n:
                rows[n_rows:n_rows + m, :] = X
                n_rows += m
            else:
                tracking = False
        raw[k, :] = delta
        factor = 1.0
        if has_limits:
            for i in range(n):
                step = delta[i]
                if step > upper[i]:
                    factor = min(factor, upper[i] / step)
                elif step < lower[i]:
                    factor = min(factor, lower[i] / step)
            if factor < 1.0:
                delta = delta * factor
            for i in range(n):
                f = BUDGET_FLOOR * limits[i]
                upper[i] = max(upper[i] - delta[i], f)
                lower[i] = min(lower[i] - delta[i], -f)
        applied[k, :] = delta
        factors[k] = factor
        rho += delta
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
