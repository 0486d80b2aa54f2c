"""``condition`` leaf: SUCCESS if its predicate holds at this tick, else FAILURE."""

from __future__ import annotations

from py_trees.common import Status

from .base import MissionLeaf
from .context import MissionContext
from .predicates import PredicateEval


class Condition(MissionLeaf):
    """Check one predicate (see :mod:`behaviours.predicates`); never RUNNING."""

    def __init__(self, name: str, ctx: MissionContext, predicate: PredicateEval):
        super().__init__(name, ctx)
        self.predicate = predicate

    def initialise(self) -> None:
        self.predicate.reset()

    def update(self) -> Status:
        ok, detail = self.predicate.holds(self.ctx)
        self.feedback_message = detail
        return Status.SUCCESS if ok else Status.FAILURE
