"""iCAT regularized pseudo-inverse and task-priority inverse kinematics (TPIK).

Spec: ../shared/spec/icat.md (MARIS eq. 11-12). A *level* is one priority level
of the hierarchy: a Jacobian ``J`` (m x n, w.r.t. the system velocity
``ydot = [qdot; v]``), an activation vector ``a`` in [0, 1]^m (the diagonal of
A) and a reference rate ``xdot`` (m,), in the task's own units per second.
Levels are given highest priority first, as ``(J, a, xdot)`` tuples or as
:class:`Level` instances (which also carry per-level ``lam``/``threshold``).

Public API
----------
* :func:`icat_pinv` - ``X^{#,A,Q}`` for one matrix.
* :func:`tpik` - the velocity ``ydot`` (n,) solving a whole stack.
* :func:`tpik_trace` - the same, plus every level's raw and saturated increment.
* :class:`Level` - one level with optional per-level regularization.

Options of :func:`tpik`:

* ``limits`` (n,): per-DOF velocity bounds ``|ydot_i| <= limits_i`` (>= 0, inf
  allowed). Each level's increment is scaled uniformly into the remaining budget
  (direction kept); budgets shrink by what was used but never below 10 % of the
  limit; the sum is finally rescaled uniformly into the limits.
* ``min_velocity=True`` appends the final "minimize all velocities" level
  (``J = I``, ``a = 1``, ``xdot = 0``) and really runs it, so that whatever
  freedom is left is spent keeping ``ydot`` small.

How it is made fast (the straightforward transcription is kept in
:mod:`kcl.icat_reference` as the test oracle and benchmark baseline; the
tests check both agree to 1e-9):

* Rows with zero activation are dropped (exact: they add nothing to any term);
  a level whose activations are all zero is skipped.
* ``P_k = X^{#,A,I}`` is built from the eigendecomposition of the small m x m
  Gram matrix ``B B^T``, ``B = sqrt(A) X`` (same non-zero spectrum as
  ``X^T A X``), in closed form when m = 1.
* ``W_k`` is never formed: only ``W_k (xdot_k - J_k rho)`` is needed, from the
  eigendecomposition of ``X^T A X + eta (I-Q)^T (I-Q) = Z^T Z`` with
  ``Z = [B; sqrt(eta) (I-Q)]`` (``I - Q`` is updated alongside Q) and
  matrix-vector products. For the first executed level Q = I and W = X P.
* RegPinv of a symmetric PSD matrix uses its symmetric eigendecomposition
  instead of an SVD (the same thing for PSD matrices).
* Q is not updated after the last level.
* Input validation is one ``isfinite`` over the concatenation of all inputs.

Two implementations of the recursion share this algebra: the compiled kernel
:mod:`kcl.icat_kernel` (Numba; used when available, ~0.15 ms for the 9-level,
13-DOF pass of ``benchmarks/tpik_pass.py``; it replaces eigendecompositions by
Cholesky solves whenever every eigenvalue is above the threshold, works in the
span of the rows seen so far, and skips levels whose ``||sqrt(A) X||_F^2`` is
below 1e-8, see its docstring) and :func:`_solve` here (numpy, with LAPACK
``dsyev`` called directly through SciPy's Cython LAPACK table; ~0.4-0.5 ms),
used when Numba is missing or ``MARIS_ICAT_NO_JIT=1``. The first process on a
machine compiles the kernel (several seconds, cached in ``kcl/__pycache__``).

Per control cycle the controller does not build level tuples: it writes the
rows straight into a preallocated :class:`kcl.icat_stacked.StackedLevels` and calls
:func:`kcl.icat_stacked.solve_stacked` (one compiled validation pass, one kernel call; same
result as :func:`tpik`).
"""

from __future__ import annotations

import math
import os
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from kcl.icat_eigh import _DSYEV_STATE, _dsyev  # noqa: F401 - switched by tests and benchmarks
from kcl.icat_numpy import BUDGET_FLOOR, ZERO_SINGULAR_VALUE, _solve

__all__ = [
    "Level",
    "TpikTrace",
    "icat_pinv",
    "tpik",
    "tpik_trace",
    "warm_up",
    "regularized_gains",
    "ZERO_SINGULAR_VALUE",
    "BUDGET_FLOOR",
]


@dataclass(frozen=True, eq=False)  # eq on arrays would be ambiguous
class Level:
    """One priority level: ``J`` (m x n), activations ``a`` (m,) in [0, 1],
    reference rate ``xdot`` (m,). ``lam``/``threshold`` override the call's
    regularization for this level (None = use the call's value); ``name`` only
    appears in error messages."""

    J: np.ndarray
    a: np.ndarray
    xdot: np.ndarray
    lam: float | None = None
    threshold: float | None = None
    name: str | None = None


LevelLike = Level | tuple


@dataclass
class TpikTrace:
    """Result of :func:`tpik_trace`.

    ``raw[k]`` is level k's increment before saturation, ``applied[k]`` after
    (both (n,); None for a skipped level), ``factors[k]`` the saturation factor
    in [0, 1] (1.0 when unsaturated, None when skipped); ``final_scale`` the
    last uniform rescale into the limits; ``ydot`` the result. Levels are
    indexed as given, the appended minimum-velocity level last.
    """

    ydot: np.ndarray
    raw: list = field(default_factory=list)
    applied: list = field(default_factory=list)
    factors: list = field(default_factory=list)
    final_scale: float = 1.0


# ----------------------------------------------------------------------------
# Regularization
# ----------------------------------------------------------------------------


def regularized_gains(s: np.ndarray, lam: float, threshold: float) -> np.ndarray:
    """Map singular values ``s`` of M to those of RegPinv(M; lam, threshold).

    ``s / (s^2 + p(s))`` with ``p(s) = lam (0.5 cos(pi s / th) + 0.5)`` for
    ``s <= th`` (0 above), and exactly 0 for ``s <= 1e-8`` (this includes the
    tiny negative eigenvalues rounding gives a PSD matrix).
    """
    p = lam * (0.5 + 0.5 * np.cos(np.minimum(s, threshold) * (np.pi / threshold)))
    out = np.zeros_like(s)
    np.divide(s, s * s + p, out=out, where=s > ZERO_SINGULAR_VALUE)
    return out


def _check_params(lam: float, threshold: float, where: str) -> None:
    if not (0.0 <= lam < math.inf):  # also False for NaN
        raise ValueError(f"{where}: lam must be finite and >= 0 (got {lam!r})")
    if not (0.0 < threshold < math.inf):
        raise ValueError(f"{where}: threshold must be finite and > 0 (got {threshold!r})")


def _check_eta(eta: float) -> None:
    if not (0.0 <= eta < math.inf):
        raise ValueError(f"eta must be finite and >= 0 (got {eta!r})")


def icat_pinv(
    X: np.ndarray,
    a: np.ndarray,
    Q: np.ndarray,
    *,
    lam: float = 1e-4,
    threshold: float = 1e-2,
    eta: float = 1.0,
) -> np.ndarray:
    """iCAT pseudo-inverse ``RegPinv(X^T A X + eta (I-Q)^T (I-Q)) X^T A A``.

    ``X`` (m x n), ``a`` (m,) the diagonal of A with entries in [0, 1],
    ``Q`` (n x n). Returns the n x m matrix. With ``lam = 0``, ``a = 1`` and
    ``Q = I`` it is the Moore-Penrose pseudo-inverse of X (singular values of
    ``X^T X`` above 1e-8 are inverted).
    """
    X = np.asarray(X, dtype=float)
    a = np.asarray(a, dtype=float)
    Q = np.asarray(Q, dtype=float)
    if X.ndim != 2:
        raise ValueError(f"icat_pinv: X must be 2-D (got shape {X.shape})")
    m, n = X.shape
    if a.shape != (m,):
        raise ValueError(f"icat_pinv: a must have shape ({m},) (got {a.shape})")
    if Q.shape != (n, n):
        raise ValueError(f"icat_pinv: Q must have shape ({n}, {n}) (got {Q.shape})")
    if not np.isfinite(np.concatenate((X.ravel(), a, Q.ravel()))).all():
        raise ValueError("icat_pinv: X, a or Q contains NaN or inf")
    if a.size and not (a.min() >= 0.0 and a.max() <= 1.0):
        raise ValueError("icat_pinv: activation a outside [0, 1]")
    _check_params(lam, threshold, "icat_pinv")
    _check_eta(eta)
    IQ = np.eye(n) - Q
    M = X.T @ (a[:, None] * X) + eta * (IQ.T @ IQ)
    w, V = np.linalg.eigh(M)
    G = (V * regularized_gains(w, lam, threshold)) @ V.T
    return G @ (X.T * (a * a))


# ----------------------------------------------------------------------------
# Input preparation and validation
# ----------------------------------------------------------------------------


def _label(k: int, name: str | None) -> str:
    return f"level {k}" if name is None else f"level {k} ({name})"


def _prepare(
    levels: Sequence[LevelLike], lam: float, threshold: float, eta: float, min_velocity: bool, limits
) -> tuple[list, int, np.ndarray | None, tuple]:
    """Normalise and validate the levels.

    Returns ``(items, n, limits, flat)``; an item is ``[J, a, xdot, lam, th,
    name, None]`` with float arrays (the numpy path fills the last slot with
    ``a.tolist()``); the appended minimum-velocity level is ``[None, None,
    None, lam, th, name, None]``. ``flat`` holds the given levels' rows
    stacked: ``(J_rows, a_rows, xdot_rows)``.
    """
    _check_params(lam, threshold, "tpik")
    _check_eta(eta)
    asarray = np.asarray
    items = []
    n = -1
    for k, lv in enumerate(levels):
        name = None
        if type(lv) is tuple and len(lv) == 3:
            J, a, xdot = lv
            lam_k, th_k = lam, threshold
        elif isinstance(lv, Level):
            J, a, xdot, name = lv.J, lv.a, lv.xdot, lv.name
            lam_k = lam if lv.lam is None else lv.lam
            th_k = threshold if lv.threshold is None else lv.threshold
            if lv.lam is not None or lv.threshold is not None:
                _check_params(lam_k, th_k, _label(k, name))
        else:
            try:
                J, a, xdot = lv
            except (TypeError, ValueError):
                raise ValueError(
                    f"level {k}: expected a (J, a, xdot) tuple or a Level, got {type(lv).__name__}"
                ) from None
            lam_k, th_k = lam, threshold
        try:
            J = asarray(J, dtype=float)
            a = asarray(a, dtype=float)
            xdot = asarray(xdot, dtype=float)
        except (TypeError, ValueError) as exc:
            raise ValueError(f"{_label(k, name)}: J, a and xdot must be numeric arrays ({exc})") from None
        shape = J.shape
        if len(shape) != 2:
            raise ValueError(f"{_label(k, name)}: J must be 2-D (m x n), got shape {shape}")
        m = shape[0]
        if shape[1] != n:
            if n >= 0:
                raise ValueError(f"{_label(k, name)}: J has {shape[1]} columns but level 0 has n = {n}")
            n = shape[1]
            if n == 0:
                raise ValueError(f"{_label(k, name)}: J has no columns (n = 0)")
        if a.shape != (m,):
            raise ValueError(f"{_label(k, name)}: activation a must have shape ({m},) like J's rows, got {a.shape}")
        if xdot.shape != (m,):
            raise ValueError(
                f"{_label(k, name)}: reference xdot must have shape ({m},) like J's rows, got {xdot.shape}"
            )
        items.append([J, a, xdot, lam_k, th_k, name, None])
    if n < 0:
        raise ValueError("tpik needs at least one level (n is J.shape[1] of the first)")
    if len(items) == 1:
        J_rows, a_rows, xdot_rows = items[0][0], items[0][1], items[0][2]
    else:
        J_rows = np.concatenate([it[0] for it in items])
        a_rows = np.concatenate([it[1] for it in items])
        xdot_rows = np.concatenate([it[2] for it in items])
    # One finiteness test over everything; locate the culprit only on failure.
    if not np.isfinite(np.concatenate((J_rows.ravel(), a_rows, xdot_rows))).all():
        for k, (J, a, xdot, *_rest) in enumerate(items):
            for what, arr in (("J", J), ("activation a", a), ("reference xdot", xdot)):
                if not np.isfinite(arr).all():
                    raise ValueError(f"{_label(k, items[k][5])}: {what} contains NaN or inf")
    acts = a_rows.tolist()  # finite now, so Python min/max are safe
    if acts and (min(acts) < 0.0 or max(acts) > 1.0):
        for k, item in enumerate(items):
            a = item[1].tolist()
            if a and (min(a) < 0.0 or max(a) > 1.0):
                raise ValueError(f"{_label(k, item[5])}: activation outside [0, 1] (min {min(a):g}, max {max(a):g})")

    if limits is not None:
        limits = np.asarray(limits, dtype=float)
        if limits.shape != (n,):
            raise ValueError(f"limits must have shape ({n},), got {limits.shape}")
        if np.isnan(limits).any() or (limits < 0).any():
            raise ValueError("limits must be >= 0 and not NaN (inf = unbounded)")
    flat = (J_rows, a_rows, xdot_rows)
    if min_velocity:
        items.append([None, None, None, lam, threshold, "minimum velocity", None])
    return items, n, limits, flat


# ----------------------------------------------------------------------------
# Dispatch: compiled kernel or numpy path
# ----------------------------------------------------------------------------


_KERNEL_STATE: list = []  # [solve function or None], filled on first use


def _kernel():
    """The compiled recursion of :mod:`kcl.icat_kernel`, or None (numpy path)
    when Numba is missing or the environment sets ``MARIS_ICAT_NO_JIT=1``."""
    if not _KERNEL_STATE:
        solve = None
        if os.environ.get("MARIS_ICAT_NO_JIT", "") in ("", "0"):
            try:
                from kcl import icat_kernel

                solve = icat_kernel.solve
            except ImportError:
                solve = None
        _KERNEL_STATE.append(solve)
    return _KERNEL_STATE[0]


def _run(items: list, n: int, eta: float, limits, flat, min_velocity: bool, trace: TpikTrace | None) -> np.ndarray:
    """Dispatch to the compiled kernel, or to the numpy path without Numba."""
    kernel = _kernel()
    if kernel is None:
        for item in items:
            if item[1] is not None:
                item[6] = item[1].tolist()
        return _solve(items, n, eta, limits, trace)
    # Exact dtypes and C layout: anything else would make Numba compile
    # another specialization (seconds) in the middle of a control loop.
    contiguous = np.ascontiguousarray
    J_rows, a_rows, xdot_rows = (contiguous(v) for v in flat)
    n_given = len(items) - (1 if min_velocity else 0)
    offsets = [0]
    for item in items[:n_given]:
        offsets.append(offsets[-1] + item[1].shape[0])
    total = len(items)
    raw = np.empty((total, n))
    applied = np.empty((total, n))
    factors = np.empty(total)
    mv = items[-1]
    rho, final = kernel(
        J_rows,
        a_rows,
        xdot_rows,
        np.array(offsets, dtype=np.int64),
        np.array([it[3] for it in items[:n_given]], dtype=float),
        np.array([it[4] for it in items[:n_given]], dtype=float),
        bool(min_velocity),
        float(mv[3]),
        float(mv[4]),
        float(eta),
        contiguous(limits) if limits is not None else np.zeros(n),
        limits is not None,
        raw,
        applied,
        factors,
    )
    if trace is not None:
        for k in range(total):
            if factors[k] < 0.0:
                trace.raw.append(None)
                trace.applied.append(None)
                trace.factors.append(None)
            else:
                trace.raw.append(raw[k].copy())
                trace.applied.append(applied[k].copy())
                trace.factors.append(float(factors[k]))
        trace.final_scale = float(final)
    return rho


def warm_up() -> bool:
    """Load (first time on a machine: compile, several seconds) the compiled
    kernel now rather than in the first control cycle. Returns True when the
    compiled path is active, False when the numpy path is used."""
    J = np.array([[1.0, 0.0], [0.0, 1.0]])
    tpik([(J, np.array([1.0, 0.5]), np.zeros(2))], limits=np.ones(2), min_velocity=True)
    if _kernel() is None:
        return False
    from kcl.icat_stacked import StackedLevels, solve_stacked

    stack = StackedLevels(2, 2, 1)
    stack.J[:] = J
    stack.a[:] = (1.0, 0.5)
    stack.close_level(2, 1e-4, 1e-2, None)
    solve_stacked(stack, lam=1e-4, threshold=1e-2, limits=np.ones(2))
    return True


def tpik(
    levels: Sequence[LevelLike],
    *,
    lam: float = 1e-4,
    threshold: float = 1e-2,
    eta: float = 1.0,
    limits: np.ndarray | None = None,
    min_velocity: bool = False,
) -> np.ndarray:
    """Solve a priority stack; returns ``ydot`` (n,), n = ``J.shape[1]``.

    ``levels``: ``(J, a, xdot)`` tuples or :class:`Level` s, highest priority
    first. ``lam``/``threshold``: default regularization of RegPinv (a
    :class:`Level` may override them). ``eta``: weight of the
    ``(I-Q)^T (I-Q)`` term. ``limits``: optional per-DOF velocity bounds
    (None: no saturation). ``min_velocity``: append and run the final
    ``J = I, a = 1, xdot = 0`` level. Raises ValueError naming the level on
    shape mismatch, NaN/inf or activations outside [0, 1].

    Underactuated vehicles: put ``J = [0 I6]``, ``a`` = 1 on the non-actuated
    DOFs, ``xdot`` = measured velocity on top; those components of the result
    then equal the measured velocities (unless the final rescale into
    ``limits`` shrinks the whole vector; discard them before commanding).
    """
    items, n, limits, flat = _prepare(levels, lam, threshold, eta, min_velocity, limits)
    return _run(items, n, eta, limits, flat, min_velocity, None)


def tpik_trace(
    levels: Sequence[LevelLike],
    *,
    lam: float = 1e-4,
    threshold: float = 1e-2,
    eta: float = 1.0,
    limits: np.ndarray | None = None,
    min_velocity: bool = False,
) -> TpikTrace:
    """Like :func:`tpik`, also returning every level's increments (telemetry, tests)."""
    items, n, limits, flat = _prepare(levels, lam, threshold, eta, min_velocity, limits)
    trace = TpikTrace(ydot=np.zeros(n))
    trace.ydot = _run(items, n, eta, limits, flat, min_velocity, trace)
    return trace
