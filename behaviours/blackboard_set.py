"""``set`` leaf: write a value to (or add a number to) a mission blackboard key."""

from __future__ import annotations

from typing import Any

from py_trees.common import Status

from .base import MissionLeaf
from .context import MissionContext


class SetBlackboard(MissionLeaf):
    """Write ``value`` to ``key``, or add ``add`` to it (an unset key counts as 0).

    FAILURE (with the reason as feedback and an event) if the value does not
    fit the key's type.
    """

    def __init__(self, name: str, ctx: MissionContext, key: str, value: Any = None, add: float | None = None):
        super().__init__(name, ctx)
        self.key, self.value, self.add = key, value, add

    def update(self) -> Status:
        bb = self.ctx.blackboard
        try:
            if self.add is not None:
                current = bb.get(self.key, 0)
                new = current + self.add
                if bb.types.get(self.key) == "int":
                    new = int(new)
                bb.set(self.key, new)
            else:
                bb.set(self.key, self.value)
        except (TypeError, KeyError) as exc:
            self.feedback_message = str(exc)
            self.emit("blackboard_error", str(exc), key=self.key, level="warning")
            return Status.FAILURE
        self.feedback_message = f"{self.key} = {bb.get(self.key)!r}"
        return Status.SUCCESS
