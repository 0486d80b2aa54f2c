"""What an operator's request does to a running mission.

At each tree step the loop runs the pollers (keys, signals, the operator
script, the live server) and then applies every request they queued:
``pause`` stops the motion and holds the tree, remembering the controller's
action; ``resume`` restores that action and ticks on; ``toggle`` is whichever
of the two applies; ``abort`` runs the abort path; ``stop_now``, or a second
``abort`` while the abort path runs, goes to the safe stop at once.
"""

from __future__ import annotations

from collections.abc import Callable

from mission.runtime.context import EventSink, RuntimeContext
from mission.runtime.endings import Endings
from mission.runtime.lifecycle import Lifecycle
from mission.runtime.operator import Commands
from mission.runtime.trees import TreeRunner

#: Called at each tree step with the backend time (s); may queue requests.
Poller = Callable[[float], None]


class OperatorRequests:
    """The operator's requests applied to the run's lifecycle."""

    def __init__(
        self,
        commands: Commands,
        pollers: list[Poller],
        lifecycle: Lifecycle,
        events: EventSink,
        ctx: RuntimeContext,
        trees: TreeRunner,
        endings: Endings,
    ) -> None:
        self.commands = commands
        self.pollers = pollers
        self.lifecycle = lifecycle
        self.events = events
        self.ctx = ctx
        self.trees = trees
        self.endings = endings
        self._paused_action: str | None = None

    def poll(self, now: float) -> None:
        """Run the pollers, then apply every queued request, in order."""
        for poll in self.pollers:
            poll(now)
        for cmd, source in self.commands.drain():
            self.apply(cmd, source)

    def apply(self, cmd: str, source: str) -> None:
        """Apply one request ``cmd`` from ``source`` (see the module docstring)."""
        lifecycle = self.lifecycle
        state = lifecycle.state
        if cmd == "toggle":
            cmd = "pause" if state == "running" else "resume"
        self.events.emit("operator", f"{cmd} ({source})", command=cmd, source=source)
        if cmd == "pause" and state == "running":
            self._paused_action = self.trees.current_action()
            self.ctx.stop_motion()
            lifecycle.go("pause", source)
        elif cmd == "resume" and state == "paused":
            now = self.ctx.clock.now()
            if self._paused_action is not None:
                self.ctx.controller.set_action(self._paused_action, now)
            lifecycle.go("resume", source)
        elif cmd == "abort" and lifecycle.can("abort"):
            self.endings.begin_abort(f"operator abort ({source})")
        elif cmd == "stop_now" or (cmd == "abort" and state == "aborting"):
            self.endings.stop_now(source)
