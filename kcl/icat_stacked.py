"""Preallocated flat TPIK input, refilled every control cycle (the controller's path).

:class:`StackedLevels` holds the rows of every level of one TPIK in flat
preallocated arrays; :func:`solve_stacked` validates them in one compiled pass
and solves them in one call of the compiled kernel (:mod:`kcl.icat_kernel`),
with the same result as :func:`kcl.icat.tpik` on the equivalent levels.
"""

from __future__ import annotations

import numpy as np

from kcl.icat import Level, _kernel, _label, tpik

__all__ = ["StackedLevels", "solve_stacked"]


class StackedLevels:
    """Preallocated flat input of one TPIK, refilled every control cycle.

    Rows of the levels are stacked in ``J`` (rows x n), ``a`` and ``xdot``;
    level k owns rows ``offsets[k]:offsets[k + 1]``; ``lams`` / ``ths`` hold its
    regularization and ``names`` its label (error messages). ``count`` is the
    number of levels filled this cycle. Fill with :meth:`clear` then
    :meth:`close_level` after writing each level's rows at ``rows_used``; solve
    with :func:`solve_stacked`. Not thread-safe (one per controller and TPIK).
    """

    def __init__(self, max_rows: int, n: int, max_levels: int):
        self.n = n
        rows, levels = max(1, max_rows), max(1, max_levels)
        # every array lives in one float64 and one int64 buffer (views), so a
        # compiled call can take the stack as two arguments (kcl.arm_cycle.stack_views)
        self.fbuf = fbuf = np.zeros(rows * (n + 2) + 2 * levels + (max_levels + 1) * (2 * n + 1))
        self.ibuf = ibuf = np.zeros(3 + 2 * (max_levels + 1), dtype=np.int64)
        ibuf[:3] = (rows, n, max_levels)
        o = rows * n
        self.J = fbuf[:o].reshape((rows, n))
        self.a, o = fbuf[o : o + rows], o + rows
        self.xdot, o = fbuf[o : o + rows], o + rows
        self.lams, o = fbuf[o : o + levels], o + levels
        self.ths, o = fbuf[o : o + levels], o + levels
        k = (max_levels + 1) * n
        self.raw, o = fbuf[o : o + k].reshape((max_levels + 1, n)), o + k
        self.applied, o = fbuf[o : o + k].reshape((max_levels + 1, n)), o + k
        self.factors = fbuf[o : o + max_levels + 1]
        self.offsets = ibuf[3 : 3 + max_levels + 1]
        self.names: list[str | None] = [None] * max_levels
        self.count = 0
        self.rows_used = 0
        #: hierarchy level of each stack level, -1 after the last (kept by
        #: :func:`kcl.cycle.gather_solve`, which writes the levels itself)
        self.level_ids = ibuf[3 + max_levels + 1 :]
        self.level_ids[:] = -1
        #: set by a filler that may later restore this level layout by setting
        #: ``count`` and ``rows_used`` only; any :meth:`close_level` resets it
        self.token: object | None = None

    def clear(self) -> None:
        """Start a new fill (the level arrays keep their values until overwritten)."""
        self.count = 0
        self.rows_used = 0

    def close_level(self, rows: int, lam: float, threshold: float, name: str | None) -> None:
        """Declare the ``rows`` rows written at ``rows_used`` as the next level."""
        self.token = None
        k = self.count
        self.level_ids[k] = -1  # no longer the layout kcl.cycle.gather_solve wrote
        self.lams[k] = lam
        self.ths[k] = threshold
        self.names[k] = name
        self.rows_used += rows
        self.offsets[k + 1] = self.rows_used
        self.count = k + 1

    def levels(self) -> list[Level]:
        """The filled levels as :class:`Level` objects (copies; numpy path, tests)."""
        out = []
        for k in range(self.count):
            lo, hi = int(self.offsets[k]), int(self.offsets[k + 1])
            out.append(
                Level(
                    self.J[lo:hi].copy(),
                    self.a[lo:hi].copy(),
                    self.xdot[lo:hi].copy(),
                    lam=float(self.lams[k]),
                    threshold=float(self.ths[k]),
                    name=self.names[k],
                )
            )
        return out


_CHECK_STATE: list = []


def _check_kernel():
    if not _CHECK_STATE:
        from kcl import icat_kernel

        _CHECK_STATE.append(icat_kernel.check_stack)
    return _CHECK_STATE[0]


CHECK_MESSAGES = {
    1: "J contains NaN or inf",
    2: "activation a contains NaN or inf",
    3: "reference xdot contains NaN or inf",
    4: "activation outside [0, 1]",
}


def solve_stacked(
    stack: StackedLevels,
    *,
    lam: float,
    threshold: float,
    eta: float = 1.0,
    limits: np.ndarray,
    min_velocity: bool = True,
) -> np.ndarray:
    """:func:`tpik` on a :class:`StackedLevels` (same result), without the
    per-call normalisation: one validation pass and one compiled call.

    ``lam``/``threshold`` are those of the final minimum-velocity level (each
    stacked level carries its own). ``limits`` (n,) float64, C-contiguous.
    Raises ValueError naming the level on NaN/inf or activations outside [0, 1].
    Without the compiled kernel it falls back to :func:`tpik`.
    """
    kernel = _kernel()
    if kernel is None:
        return tpik(stack.levels(), lam=lam, threshold=threshold, eta=eta, limits=limits, min_velocity=min_velocity)
    count = stack.count
    offsets = stack.offsets[: count + 1]
    bad, code = _check_kernel()(stack.J, stack.a, stack.xdot, offsets)
    if bad >= 0:
        raise ValueError(f"{_label(bad, stack.names[bad])}: {CHECK_MESSAGES[code]}")
    rho, _final = kernel(
        stack.J,
        stack.a,
        stack.xdot,
        offsets,
        stack.lams[:count],
        stack.ths[:count],
        bool(min_velocity),
        float(lam),
        float(threshold),
        float(eta),
        limits,
        True,
        stack.raw,
        stack.applied,
        stack.factors,
    )
    return rho
