"""``wait`` leaf: RUNNING for ``duration_s`` seconds of backend clock, then SUCCESS."""

from __future__ import annotations

from py_trees.common import Status

from .base import MissionLeaf
from .context import MissionContext


class Wait(MissionLeaf):
    """Wait ``duration_s`` (s, backend clock)."""

    def __init__(self, name: str, ctx: MissionContext, duration_s: float):
        super().__init__(name, ctx)
        self.duration_s = float(duration_s)
        self._t0 = 0.0

    def initialise(self) -> None:
        self._t0 = self.ctx.now()

    def update(self) -> Status:
        elapsed = self.ctx.now() - self._t0
        self.feedback_message = f"{elapsed:.1f} / {self.duration_s:g} s"
        return Status.SUCCESS if elapsed >= self.duration_s else Status.RUNNING
