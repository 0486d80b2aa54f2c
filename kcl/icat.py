"""iCAT regularized pseudo-inverse and task-priority inverse kinematics (TPIK).

Spec: ../shared/spec/icat.md (MARIS eq. 11-12). A *level* is one priority level
of the hierarchy: a Jacobian ``J`` (m x n, w.r.t. the system velocity
``ydot = [qdot; v]``), an activation vector ``a`` in [0, 1]^m (the diagonal of
A) and a reference rate ``xdot`` (m,), in the task's own units per second.
Levels are given highest priority first, as ``(J, a, xdot)`` tuples or as
:class:`Level` instances (which also carry per-level ``lam``/``threshold``).

* :func:`tpik` - the velocity ``ydot`` (n,) solving a whole stack.
* :func:`tpik_trace` - the same, plus every level's raw and saturated increment.

Options of :func:`tpik`: ``limits`` (n,) per-DOF bounds ``|ydot_i| <= limits_i``
(>= 0, inf allowed): each level's increment is scaled uniformly into the
remaining budget (direction kept), budgets shrink by what was used but never
below 10 % of the limit, and the sum is finally rescaled uniformly into the
limits. ``min_velocity=True`` appends and really runs the final "minimize all
velocities" level (``J = I``, ``a = 1``, ``xdot = 0``).

This module validates its arguments (a ValueError naming the level) and runs the
compiled recursion of :mod:`kcl.icat_kernel`, the same solver the controller's
cycle (:mod:`kcl.cycle`) runs.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from kcl.icat_kernel import BUDGET_FLOOR, ZERO_SINGULAR_VALUE, solve

__all__ = [
    "Level",
    "TpikTrace",
    "tpik",
    "tpik_trace",
    "CHECK_MESSAGES",
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


def _check_params(lam: float, threshold: float, where: str) -> None:
    if not (0.0 <= lam < math.inf):  # also False for NaN
        raise ValueError(f"{where}: lam must be finite and >= 0 (got {lam!r})")
    if not (0.0 < threshold < math.inf):
        raise ValueError(f"{where}: threshold must be finite and > 0 (got {threshold!r})")


def _check_eta(eta: float) -> None:
    if not (0.0 <= eta < math.inf):
        raise ValueError(f"eta must be finite and >= 0 (got {eta!r})")


def _label(k: int, name: str | None) -> str:
    return f"level {k}" if name is None else f"level {k} ({name})"


@dataclass(frozen=True, eq=False)
class _Prepared:
    """Validated levels, as :func:`_run` hands them to the kernel: the rows of
    every given level stacked (``J``, ``a``, ``xdot``), where each level starts
    (``offsets``), their regularization, the limits (None: no saturation)."""

    n: int
    J: np.ndarray
    a: np.ndarray
    xdot: np.ndarray
    offsets: np.ndarray
    lams: np.ndarray
    ths: np.ndarray
    limits: np.ndarray | None


def _as_level(k: int, lv: Any, lam: float, threshold: float) -> Level:
    """Level ``k`` as a :class:`Level` with float arrays and its own regularization."""
    if isinstance(lv, Level):
        lam_k = lam if lv.lam is None else lv.lam
        th_k = threshold if lv.threshold is None else lv.threshold
        if lv.lam is not None or lv.threshold is not None:
            _check_params(lam_k, th_k, _label(k, lv.name))
        J, a, xdot, name = lv.J, lv.a, lv.xdot, lv.name
    else:
        try:
            J, a, xdot = lv
        except (TypeError, ValueError):
            raise ValueError(f"level {k}: expected a (J, a, xdot) tuple or a Level, got {type(lv).__name__}") from None
        lam_k, th_k, name = lam, threshold, None
    try:
        return Level(
            np.asarray(J, dtype=float), np.asarray(a, dtype=float), np.asarray(xdot, dtype=float), lam_k, th_k, name
        )
    except (TypeError, ValueError) as exc:
        raise ValueError(f"{_label(k, name)}: J, a and xdot must be numeric arrays ({exc})") from None


def _prepare(
    levels: Sequence[LevelLike], lam: float, threshold: float, eta: float, limits: np.ndarray | None
) -> _Prepared:
    """Validate the levels (shapes, finite values, activations in [0, 1], limits);
    a ValueError names the first bad level."""
    _check_params(lam, threshold, "tpik")
    _check_eta(eta)
    items = [_as_level(k, lv, lam, threshold) for k, lv in enumerate(levels)]
    if not items:
        raise ValueError("tpik needs at least one level (n is J.shape[1] of the first)")
    n = -1
    for k, lv in enumerate(items):
        where = _label(k, lv.name)
        if lv.J.ndim != 2:
            raise ValueError(f"{where}: J must be 2-D (m x n), got shape {lv.J.shape}")
        m, cols = lv.J.shape
        if n < 0:
            n = cols
            if n == 0:
                raise ValueError(f"{where}: J has no columns (n = 0)")
        elif cols != n:
            raise ValueError(f"{where}: J has {cols} columns but level 0 has n = {n}")
        if lv.a.shape != (m,):
            raise ValueError(f"{where}: activation a must have shape ({m},) like J's rows, got {lv.a.shape}")
        if lv.xdot.shape != (m,):
            raise ValueError(f"{where}: reference xdot must have shape ({m},) like J's rows, got {lv.xdot.shape}")
        for what, arr in (("J", lv.J), ("activation a", lv.a), ("reference xdot", lv.xdot)):
            if not np.isfinite(arr).all():
                raise ValueError(f"{where}: {what} contains NaN or inf")
        if lv.a.size and (lv.a.min() < 0.0 or lv.a.max() > 1.0):
            raise ValueError(f"{where}: activation outside [0, 1] (min {lv.a.min():g}, max {lv.a.max():g})")
    if limits is not None:
        limits = np.asarray(limits, dtype=float)
        if limits.shape != (n,):
            raise ValueError(f"limits must have shape ({n},), got {limits.shape}")
        if np.isnan(limits).any() or (limits < 0).any():
            raise ValueError("limits must be >= 0 and not NaN (inf = unbounded)")
    sizes = [lv.a.shape[0] for lv in items]
    return _Prepared(
        n=n,
        J=np.ascontiguousarray(np.concatenate([lv.J for lv in items])),
        a=np.ascontiguousarray(np.concatenate([lv.a for lv in items])),
        xdot=np.ascontiguousarray(np.concatenate([lv.xdot for lv in items])),
        offsets=np.concatenate([[0], np.cumsum(sizes)]).astype(np.int64),
        lams=np.array([lv.lam for lv in items], dtype=float),
        ths=np.array([lv.threshold for lv in items], dtype=float),
        limits=limits,
    )


CHECK_MESSAGES = {
    1: "J contains NaN or inf",
    2: "activation a contains NaN or inf",
    3: "reference xdot contains NaN or inf",
    4: "activation outside [0, 1]",
}
"""The reasons of :func:`kcl.icat_kernel.check_stack`'s codes."""


def _run(
    levels: Sequence[LevelLike],
    lam: float,
    threshold: float,
    eta: float,
    limits: np.ndarray | None,
    min_velocity: bool,
) -> TpikTrace:
    """Validate, then run the compiled recursion of :mod:`kcl.icat_kernel`."""
    prep = _prepare(levels, lam, threshold, eta, limits)
    n = prep.n
    total = prep.lams.shape[0] + (1 if min_velocity else 0)
    raw = np.empty((total, n))
    applied = np.empty((total, n))
    factors = np.empty(total)
    has_limits = prep.limits is not None
    rho, final = solve(
        prep.J,
        prep.a,
        prep.xdot,
        prep.offsets,
        prep.lams,
        prep.ths,
        bool(min_velocity),
        float(lam),
        float(threshold),
        float(eta),
        np.ascontiguousarray(prep.limits) if prep.limits is not None else np.zeros(n),
        has_limits,
        raw,
        applied,
        factors,
    )
    trace = TpikTrace(ydot=rho, final_scale=float(final))
    for k in range(total):
        skipped = factors[k] < 0.0
        trace.raw.append(None if skipped else raw[k].copy())
        trace.applied.append(None if skipped else applied[k].copy())
        trace.factors.append(None if skipped else float(factors[k]))
    return trace


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
    return _run(levels, lam, threshold, eta, limits, min_velocity).ydot


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
    return _run(levels, lam, threshold, eta, limits, min_velocity)
