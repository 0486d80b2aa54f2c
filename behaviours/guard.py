"""``guard`` decorator: the child runs only while a condition keeps holding.

Built on py_trees' EternalGuard: the predicate is evaluated before every tick
of the child; when it stops holding, the running child is halted (INVALID, so
its halt contract applies) and the guard returns FAILURE. A ``guard_failed``
event says which condition broke.
"""

from __future__ import annotations

import py_trees

from .context import MissionContext
from .predicates import PredicateEval


def make_guard(
    name: str, child: py_trees.behaviour.Behaviour, ctx: MissionContext | None, predicate: PredicateEval
) -> py_trees.decorators.EternalGuard:
    """Guard ``child`` with ``predicate`` (``ctx`` None: display only, never ticked)."""

    def condition() -> bool:
        if ctx is None:
            raise RuntimeError(f"guard {name}: built for display (no context), never ticked")
        ok, detail = predicate.holds(ctx)
        if not ok:
            ctx.events.emit(
                "guard_failed", f"guard `{predicate.describe()}` no longer holds: {detail}", node=name, level="warning"
            )
        return bool(ok)  # EternalGuard raises on anything but a plain bool (e.g. numpy.bool_)

    return py_trees.decorators.EternalGuard(name, child, condition=condition)
