"""The mission's behaviour trees as the supervisor runs them.

:class:`TreeRunner` builds the main tree and the abort path once, before
anything moves (a broken abort path then shows before motion), ticks either one
at the tree rate, and keeps what the run reports of them: the tip leaf, the
action switch times, and their statuses and the blackboard in the log. It
decides nothing about the run's end; :class:`mission.runtime.endings.Endings`
does, from what the ticks return.
"""

from __future__ import annotations

import traceback
from collections.abc import Callable
from dataclasses import dataclass

from py_trees.behaviour import Behaviour
from py_trees.common import Status

from hal.interfaces import Clock
from kcl.telemetry import controller_status
from mission.runtime.context import RuntimeContext
from mission.runtime.recorder import RunRecorder

#: Builds a tree's root for the run's context (``mission.compiler.compile_mission`` /
#: ``compile_abort`` bound to the mission).
TreeFactory = Callable[[RuntimeContext], Behaviour]


@dataclass(frozen=True)
class ActionSwitch:
    """The controller's action changed to ``action`` at backend time ``t`` (s)."""

    t: float
    action: str


@dataclass(frozen=True)
class LeafError:
    """A software error raised while ticking the main tree."""

    #: ``internal error: <type>: <message>``, the run's failure cause.
    cause: str
    #: The leaf last ticked (or the tree's name), where it happened.
    where: str
    traceback: str


class TreeRunner:
    """The main tree and the abort path of one run (see the module docstring)."""

    def __init__(
        self,
        make_tree: TreeFactory,
        make_abort_tree: TreeFactory | None,
        ctx: RuntimeContext,
        rec: RunRecorder,
        *,
        raise_errors: bool = False,
    ) -> None:
        """``raise_errors``: a leaf's software error propagates instead of being
        returned as a :class:`LeafError` (``SupervisorOptions.raise_internal_errors``)."""
        self.make_tree = make_tree
        self.make_abort_tree = make_abort_tree
        self.ctx = ctx
        self.clock: Clock = ctx.clock
        self.controller = ctx.controller
        self.rec = rec
        self.raise_errors = raise_errors
        #: The main tree's root (None until :meth:`build`).
        self.main: Behaviour | None = None
        #: The abort path's root, built with the main tree (None without one).
        self.abort_root: Behaviour | None = None
        #: The abort path while it runs (None when it is not running).
        self.abort_running: Behaviour | None = None
        #: Name of the leaf the last tick ended on.
        self.leaf: str | None = None
        #: The controller's action switches seen after the ticks, in time order.
        self.switches: list[ActionSwitch] = []

    @property
    def has_abort_path(self) -> bool:
        return self.make_abort_tree is not None

    def build(self) -> None:
        """Build and set up the main tree and the abort path."""
        self.main = self.make_tree(self.ctx)
        self.main.setup_with_descendants()
        if self.make_abort_tree is not None:
            self.abort_root = self.make_abort_tree(self.ctx)
            self.abort_root.setup_with_descendants()

    def name(self) -> str:
        """Where the run is in the main tree: the tip leaf, else the tree's name."""
        return self.leaf or (self.main.name if self.main is not None else "")

    # ------------------------------------------------------------ main tree
    def tick_main(self) -> Status | LeafError:
        """One tick of the main tree: its status, or the software error a leaf raised
        (the tree is then left as the error found it)."""
        assert self.main is not None, "build() first"
        try:
            self.main.tick_once()
        except Exception as exc:  # noqa: BLE001 - a leaf's software error: the caller runs the abort path
            if self.raise_errors:
                raise
            return LeafError(f"internal error: {type(exc).__name__}: {exc}", self.name(), traceback.format_exc())
        self._after_tick(self.main)
        return self.main.status

    def main_running(self) -> bool:
        return self.main is not None and self.main.status == Status.RUNNING

    def halt_main(self) -> None:
        """Interrupt the running main tree (its leaves halt: zero commands); raises what a leaf raises."""
        if self.main is not None:
            self.main.stop(Status.INVALID)

    # ----------------------------------------------------------- abort path
    def start_abort(self) -> bool:
        """Make the built abort path the running one; False when there is none."""
        self.abort_running = self.abort_root
        return self.abort_running is not None

    def tick_abort(self) -> Status | None:
        """One tick of the running abort path: its status (None when none runs)."""
        tree = self.abort_running
        if tree is None:
            return None
        tree.tick_once()
        self._after_tick(tree)
        return tree.status

    def halt_abort(self) -> None:
        """Interrupt the running abort path (e.g. at its deadline)."""
        if self.abort_running is not None:
            self.abort_running.stop(Status.INVALID)

    def drop_abort(self) -> None:
        """The abort path ended: none runs any more."""
        self.abort_running = None

    # -------------------------------------------------------------- reports
    def current_action(self) -> str | None:
        """The controller's current action."""
        try:
            return self.controller.current_action
        except AttributeError:
            return controller_status(self.controller).get("action")

    def _after_tick(self, root: Behaviour) -> None:
        tip = root.tip()
        self.leaf = tip.name if tip is not None else None
        action = self.current_action()
        if action is not None and (not self.switches or self.switches[-1].action != action):
            self.switches.append(ActionSwitch(self.clock.now(), action))
        now = self.clock.now()
        self.rec.tree(now, root, self.leaf, self.ctx.blackboard)
        self.rec.operator(now, self.ctx.operator.status)
