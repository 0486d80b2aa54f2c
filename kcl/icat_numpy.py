"""The numpy path of the TPIK recursion (used without Numba or with ``MARIS_ICAT_NO_JIT=1``).

Same algebra as the compiled kernel :mod:`kcl.icat_kernel` (see the
:mod:`kcl.icat` docstring for how it is made fast), in numpy with direct LAPACK
eigendecompositions (:mod:`kcl.icat_eigh`) and plain-Python saturation.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np

from kcl.icat_eigh import _eigh_product

if TYPE_CHECKING:
    from kcl.icat import TpikTrace

#: Singular values at or below this are treated as exactly zero.
ZERO_SINGULAR_VALUE = 1e-8
#: Per-level saturation budgets never shrink below this fraction of the limit.
BUDGET_FLOOR = 0.1


def _gains(s: np.ndarray, lam: float, th: float) -> np.ndarray:
    """:func:`regularized_gains` for a handful of values, in plain Python."""
    return np.array([_gain(v, lam, th) for v in s.tolist()])


def _gain(v: float, lam: float, th: float) -> float:
    """:func:`regularized_gains` of one singular value."""
    if v > th:
        return 1.0 / v
    if v <= ZERO_SINGULAR_VALUE:
        return 0.0
    return v / (v * v + lam * (0.5 * math.cos(math.pi * v / th) + 0.5))


# ----------------------------------------------------------------------------
# Solver
# ----------------------------------------------------------------------------


def _saturate(delta: np.ndarray, upper: list, lower: list, floor: list):
    """Scale ``delta`` into the budgets [lower, upper]; shrink the budgets.

    Returns (delta, factor, upper, lower). Plain Python: n is small.
    """
    values = delta.tolist()
    factor = 1.0
    for d, u, lo in zip(values, upper, lower):
        if d > u:
            q = u / d
            if q < factor:
                factor = q
        elif d < lo:
            q = lo / d
            if q < factor:
                factor = q
    if factor < 1.0:
        delta = delta * factor
        values = delta.tolist()
    upper = [u - d if u - d > f else f for d, u, f in zip(values, upper, floor)]
    lower = [lo - d if lo - d < -f else -f for d, lo, f in zip(values, lower, floor)]
    return delta, factor, upper, lower


def _solve(items: list, n: int, eta: float, limits: np.ndarray | None, trace: TpikTrace | None) -> np.ndarray:
    """The TPIK recursion on validated items (see the module docstring).

    ``Q`` and ``rho`` are updated in place. ``Zbuf`` stacks the rows of the
    current ``B = sqrt(A) X`` on top of ``sqrt(eta) (I - Q)`` (kept up to date
    alongside Q), so ``X^T A X + eta (I-Q)^T (I-Q) = Z^T Z`` is one product.
    """
    dot = np.dot
    multiply = np.multiply
    eigh = _eigh_product
    mmax = max(n if it[0] is None else len(it[6]) for it in items)
    Q = np.eye(n)
    rho = np.zeros(n)
    Zbuf = np.zeros((mmax + n, n))
    IQ = Zbuf[mmax:]  # sqrt(eta) (I - Q)
    root_eta = math.sqrt(eta)
    first = True  # no level has run yet: Q is exactly I and rho exactly 0
    if limits is not None:
        upper = limits.tolist()
        lower = [-u for u in upper]
        floor = [BUDGET_FLOOR * u for u in upper]
    last = len(items) - 1
    for k, (J, a, xdot, lam, th, _name, acts) in enumerate(items):
        update_q = k != last  # Q after the last level is never used
        D = None  # the rank-m change of Q: Q_k = Q_{k-1} - D
        if J is None:  # the minimum-velocity level: J = I, a = 1, xdot = 0
            if first:
                delta = np.zeros(n)  # rho = 0: nothing to reduce
            else:
                s, U = eigh(Q, Q.T, 0)  # Gram of B = X = Q
                Us = U * (s * _gains(s, lam, th))  # Q P = U diag(s g) U^T
                Zv = Zbuf[mmax - n :]
                Zv[:n] = Q
                sw, V = eigh(Zv.T, Zv, 1)
                C = dot(Q, V)
                minus_wr = dot(C, _gains(sw, lam, th) * dot(rho, C))  # r = -rho
                delta = dot(Us, dot(minus_wr, U))
                np.negative(delta, out=delta)
                if update_q:
                    D = dot(Us, dot(U.T, Q))
        else:
            if not acts or min(acts) <= 0.0:
                if not acts or max(acts) <= 0.0:  # empty or all-zero level: no change
                    if trace is not None:
                        trace.raw.append(None)
                        trace.applied.append(None)
                        trace.factors.append(None)
                    continue
                keep = [i for i, v in enumerate(acts) if v > 0.0]
                J, a, xdot = J[keep], a[keep], xdot[keep]
                acts = [acts[i] for i in keep]
            m = len(acts)
            if m == 1:  # scalar level: P = c x^T, closed form
                a0 = acts[0]
                j = J[0]
                if first:
                    x = j
                    r = float(xdot[0])
                else:
                    x = dot(j, Q)
                    r = float(xdot[0]) - float(dot(j, rho))
                xx = float(dot(x, x))
                c = _gain(a0 * xx, lam, th) * a0 * a0
                if first:
                    wr = c * xx * r  # W = x P
                    qp = x * c
                else:
                    Zv = Zbuf[mmax - 1 :]
                    multiply(x, math.sqrt(a0), out=Zv[0])
                    sw, V = eigh(Zv.T, Zv, 1)
                    cv = dot(x, V)
                    wr = float(dot(cv * _gains(sw, lam, th), cv)) * (a0 * a0 * r)
                    qp = dot(Q, x)
                    qp *= c
                delta = qp * wr
                if update_q:
                    D = qp[:, None] * x
            else:
                if first:
                    X = J
                    r = xdot
                else:
                    X = dot(J, Q)
                    r = xdot - dot(J, rho)
                sa = np.sqrt(a)
                Bv = Zbuf[mmax - m : mmax]
                multiply(X, sa[:, None], out=Bv)
                if m <= n:
                    # P = B^T U g U^T diag(a^1.5), U g U^T from the m x m Gram B B^T
                    s, U = eigh(Bv, Bv.T, 0)
                    P = dot(dot(Bv.T, U * _gains(s, lam, th)), U.T * (a * sa))
                else:
                    # P = V g V^T B^T diag(a^1.5) from the n x n matrix B^T B
                    s, V = eigh(Bv.T, Bv, 0)
                    P = dot(V * _gains(s, lam, th), (dot(Bv, V) * (a * sa)[:, None]).T)
                if first:
                    QP = P
                    wr = dot(X, dot(P, r))  # W = X P
                else:
                    QP = dot(Q, P)
                    Zv = Zbuf[mmax - m :]
                    sw, V = eigh(Zv.T, Zv, 1)
                    C = dot(X, V)
                    wr = dot(C, _gains(sw, lam, th) * dot((a * a) * r, C))
                delta = dot(QP, wr)
                if update_q:
                    D = dot(QP, X)
        if D is not None:
            Q -= D
            if eta == 1.0:
                IQ += D
            else:
                IQ += root_eta * D
        if trace is not None:
            trace.raw.append(delta.copy())
        factor = 1.0
        if limits is not None:
            delta, factor, upper, lower = _saturate(delta, upper, lower, floor)
        if trace is not None:
            trace.applied.append(delta.copy())
            trace.factors.append(factor)
        rho += delta
        first = False
    if limits is not None:
        final = 1.0
        for v, lim in zip(rho.tolist(), limits.tolist()):
            if abs(v) > lim:
                q = lim / abs(v)
                if q < final:
                    final = q
        if final < 1.0:
            rho *= final
        if trace is not None:
            trace.final_scale = final
    return rho
