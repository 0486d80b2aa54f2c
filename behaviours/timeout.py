"""``timeout`` decorator on the backend clock.

py_trees' own Timeout reads the wall clock; missions must follow the backend
clock (simulated time runs faster than wall time in dry runs). FAILURE when
the child still runs after ``duration_s``; the child is then halted (py_trees
stops a RUNNING child with INVALID, so its halt contract applies).
"""

from __future__ import annotations

import py_trees
from py_trees.common import Status

from .context import MissionContext


class ClockTimeout(py_trees.decorators.Decorator):
    """Fail if the child is still RUNNING ``duration_s`` (s, backend clock) after start."""

    def __init__(self, name: str, child: py_trees.behaviour.Behaviour, ctx: MissionContext, duration_s: float):
        super().__init__(name=name, child=child)
        self.ctx = ctx
        self.duration_s = float(duration_s)
        self._t0 = 0.0

    def initialise(self) -> None:
        self._t0 = self.ctx.now()

    def update(self) -> Status:
        elapsed = self.ctx.now() - self._t0
        if self.decorated.status == Status.RUNNING and elapsed >= self.duration_s:
            self.feedback_message = f"timed out after {elapsed:.1f} s (limit {self.duration_s:g} s)"
            self.ctx.events.emit("timeout", self.feedback_message, node=self.name, level="warning")
            return Status.FAILURE
        self.feedback_message = f"{elapsed:.1f} / {self.duration_s:g} s"
        return self.decorated.status
