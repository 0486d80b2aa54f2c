"""``log`` leaf: emit an operator-readable event to the run log, then SUCCESS."""

from __future__ import annotations

from py_trees.common import Status

from .base import MissionLeaf
from .context import MissionContext


class LogEvent(MissionLeaf):
    """Emit ``message`` as a ``mission_log`` event with its ``level`` (info / warning / fault, the run log's levels)."""

    def __init__(self, name: str, ctx: MissionContext, message: str, level: str = "info"):
        super().__init__(name, ctx)
        self.message, self.level = message, level

    def update(self) -> Status:
        self.emit("mission_log", self.message, level=self.level, t=self.ctx.now())
        return Status.SUCCESS
