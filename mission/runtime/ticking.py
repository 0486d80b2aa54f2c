"""Operator commands and the mission tree's tick, as the supervisor runs them: pause,
resume, abort and stop requests applied to the lifecycle; one tick of the behaviour
tree, a leaf's software error turned into the abort path, the tree's end into the
run's end; the action switch times. A mixin of
:class:`mission.runtime.supervisor.Supervisor` (it uses the supervisor's lifecycle,
tree, controller, clock, events and recorder; see the supervisor's module docstring).
"""

from __future__ import annotations

import traceback
from typing import Any

from kcl.telemetry import controller_status


class TreeTickMixin:
    """Operator requests and tree ticks of the supervisor."""

    lifecycle: Any
    controller: Any
    clock: Any
    events: Any

    # -------------------------------------------------------------- operator
    def _operator(self, cmd: str, source: str) -> None:
        state = self.lifecycle.state
        if cmd == "toggle":
            cmd = "pause" if state == "running" else "resume"
        self.events.emit("operator", f"{cmd} ({source})", command=cmd, source=source)
        if cmd == "pause" and state == "running":
            self._paused_action = self._current_action()
            self.ctx.stop_motion()
            self.lifecycle.go("pause", source)
        elif cmd == "resume" and state == "paused":
            now = self.clock.now()
            if self._paused_action is not None:
                self.controller.set_action(self._paused_action, now)
            self.lifecycle.go("resume", source)
        elif cmd == "abort" and self.lifecycle.can("abort"):
            self._begin_abort(f"operator abort ({source})")
        elif cmd == "stop_now" or (cmd == "abort" and state == "aborting"):
            self.failure_cause = self.failure_cause or f"operator stop ({source})"
            self._end_abort("safe stop on operator request")

    def _tick_tree(self) -> None:
        from py_trees.common import Status

        try:
            self.tree.tick_once()
        except Exception as exc:  # noqa: BLE001 - a leaf's software error: stop, then the abort path
            if self.options.raise_internal_errors:
                raise
            cause = f"internal error: {type(exc).__name__}: {exc}"
            self.events.emit(
                "internal_error",
                f"{cause} (in the mission tree at {self.leaf or self.tree.name}); running the abort path",
                level="fault",
                traceback=traceback.format_exc(),
            )
            self._begin_abort(cause, failed=True)
            return
        self._after_tick(self.tree)
        status = self.tree.status
        if status == Status.SUCCESS:
            self.events.emit("mission", "mission tree succeeded")
            self.act.safe_stop_all()
            self.lifecycle.go("succeed", "tree succeeded")
        elif status == Status.FAILURE:
            self._begin_abort(f"mission failed at {self.leaf or self.tree.name}", failed=True)

    def _after_tick(self, root: Any) -> None:
        tip = root.tip()
        self.leaf = tip.name if tip is not None else None
        action = self._current_action()
        if action is not None and (not self._actions or self._actions[-1][1] != action):
            self._actions.append((self.clock.now() - self.t0, action))
        self.rec.tree(self.clock.now(), root, self.leaf, self.ctx.blackboard)

    # --------------------------------------------------------------- helpers
    def _current_action(self) -> str | None:
        try:
            return self.controller.current_action
        except AttributeError:
            return controller_status(self.controller).get("action")
