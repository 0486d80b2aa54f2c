"""``retry`` decorator that logs each failed attempt.

py_trees' Retry re-runs a failing child until it has failed ``attempts``
times; this one also emits an ``attempt_failed`` event (attempt number, the
child's feedback) so run logs show why each attempt ended.
"""

from __future__ import annotations

import py_trees
from py_trees.common import Status

from .context import MissionContext


class LoggedRetry(py_trees.decorators.Retry):
    """Retry with an event per failed attempt."""

    def __init__(self, name: str, child: py_trees.behaviour.Behaviour, ctx: MissionContext, attempts: int):
        super().__init__(name=name, child=child, num_failures=attempts)
        self.ctx = ctx

    def update(self) -> Status:
        before = self.failures
        status = super().update()
        if self.failures > before:
            last = self.decorated.tip()
            tip = last if last is not None else self.decorated
            self.ctx.events.emit(
                "attempt_failed",
                f"attempt {self.failures} of {self.num_failures} failed at {tip.name}: {tip.feedback_message}",
                node=self.name,
                attempt=self.failures,
                level="warning",
            )
        return status
