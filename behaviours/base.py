"""Common base of the mission leaves: a py_trees behaviour holding the context.

Subclasses implement ``initialise`` / ``update`` / ``terminate`` and never
block. :meth:`MissionLeaf.interrupted` tells a ``terminate`` whether the leaf
is being halted while it was running (the case where the halt contract
applies: command zero velocities before returning).
"""

from __future__ import annotations

from typing import Any

import py_trees
from py_trees.common import Status

from .context import MissionContext


class MissionLeaf(py_trees.behaviour.Behaviour):
    """A leaf with a :class:`~behaviours.context.MissionContext`."""

    def __init__(self, name: str, ctx: MissionContext):
        super().__init__(name=name)
        self.ctx = ctx

    def interrupted(self, new_status: Status) -> bool:
        """True when ``terminate(new_status)`` halts a RUNNING leaf (py_trees
        calls ``terminate`` before it updates ``self.status``)."""
        return new_status == Status.INVALID and self.status == Status.RUNNING

    def emit(self, kind: str, message: str, **fields: Any) -> None:
        """Emit a log event tagged with this node's name."""
        self.ctx.events.emit(kind, message, node=self.name, **fields)
