"""Straightforward transcription of the iCAT TPIK formulas of icat.md.

This module is the tests' *oracle*: every formula is written the way the spec
states it, with full matrices, ``diag(a)``, and a full SVD inside the
regularized pseudo-inverse. It is slow and does no input validation. The KCL's
solver (:mod:`kcl.icat_kernel`, through :func:`kcl.icat.tpik` and the
controller's cycle) is tested against it, and ``benchmarks/tpik_pass.py`` uses
it as the speed baseline.

Keep it boring: do not optimise this file.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

#: Singular values at or below this are treated as exactly zero.
ZERO_SINGULAR_VALUE = 1e-8
#: Per-level budgets never shrink below this fraction of the original limit.
BUDGET_FLOOR = 0.1


def reg_pinv(M: np.ndarray, lam: float, threshold: float) -> np.ndarray:
    """Regularized pseudo-inverse RegPinv(M; lam, th) via the SVD of M."""
    U, S, Vt = np.linalg.svd(M)
    inv = np.zeros_like(S)
    for i, s in enumerate(S):
        if s <= ZERO_SINGULAR_VALUE:
            continue
        p = lam * (0.5 * np.cos(np.pi * s / threshold) + 0.5) if s <= threshold else 0.0
        inv[i] = s / (s * s + p)
    return Vt.T @ np.diag(inv) @ U.T


def icat_pinv(
    X: np.ndarray,
    a: np.ndarray,
    Q: np.ndarray,
    *,
    lam: float = 1e-4,
    threshold: float = 1e-2,
    eta: float = 1.0,
) -> np.ndarray:
    """X^{#,A,Q} = RegPinv(X^T A X + eta (I-Q)^T (I-Q)) X^T A A."""
    A = np.diag(a)
    I = np.eye(X.shape[1])
    M = X.T @ A @ X + eta * (I - Q).T @ (I - Q)
    return reg_pinv(M, lam, threshold) @ X.T @ A @ A


def saturate(delta: np.ndarray, upper: np.ndarray, lower: np.ndarray) -> np.ndarray:
    """Scale ``delta`` by the largest factor <= 1 keeping it in [lower, upper]."""
    factor = 1.0
    for i in range(delta.shape[0]):
        if delta[i] > upper[i]:
            factor = min(factor, abs(upper[i] / delta[i]))
        elif delta[i] < lower[i]:
            factor = min(factor, abs(lower[i] / delta[i]))
    return delta * factor


def tpik(
    levels: Sequence,
    *,
    lam: float = 1e-4,
    threshold: float = 1e-2,
    eta: float = 1.0,
    limits: np.ndarray | None = None,
    min_velocity: bool = False,
) -> np.ndarray:
    """TPIK recursion (MARIS eq. 11-12) with saturation, as written in icat.md.

    ``levels`` holds ``(J, a, xdot)`` tuples or objects with ``J, a, xdot`` and
    optional ``lam``/``threshold`` attributes (None = the call's default).
    """
    items = []
    for lv in levels:
        if isinstance(lv, tuple):
            J, a, xdot = lv
            items.append((np.asarray(J, float), np.asarray(a, float), np.asarray(xdot, float), lam, threshold))
        else:
            items.append(
                (
                    np.asarray(lv.J, float),
                    np.asarray(lv.a, float),
                    np.asarray(lv.xdot, float),
                    lam if lv.lam is None else lv.lam,
                    threshold if lv.threshold is None else lv.threshold,
                )
            )
    n = items[0][0].shape[1]
    if min_velocity:
        items.append((np.eye(n), np.ones(n), np.zeros(n), lam, threshold))

    I = np.eye(n)
    rho = np.zeros(n)
    Q = np.eye(n)
    if limits is not None:
        limits = np.asarray(limits, float)
        upper = limits.copy()
        lower = -limits.copy()
    for J, a, xdot, lam_k, th_k in items:
        if not np.any(a != 0):
            continue
        X = J @ Q
        W = X @ icat_pinv(X, a, Q, lam=lam_k, threshold=th_k, eta=eta)
        P = icat_pinv(X, a, I, lam=lam_k, threshold=th_k, eta=eta)
        delta = Q @ P @ W @ (xdot - J @ rho)
        if limits is not None:
            delta = saturate(delta, upper, lower)
            upper = np.maximum(upper - delta, BUDGET_FLOOR * limits)
            lower = np.minimum(lower - delta, -BUDGET_FLOOR * limits)
        rho = rho + delta
        Q = Q @ (I - P @ X)
    if limits is not None:
        rho = saturate(rho, limits, -limits)
    return rho
