"""The supervisor's lifecycle state machine (``transitions``).

::

    idle --start--> preflight --preflight_ok--> running <--pause/resume--> paused
                        |                          |  \\--succeed--> succeeded
                        |                          |   \\-fail-----> failed
                        +--preflight_failed--> failed
    preflight/running/paused --abort--> aborting --abort_done--> aborted
                                                  \\-end_failed--> failed

The terminal states are ``succeeded``, ``failed`` and ``aborted``.
``end_failed`` closes an abort path that was run because the mission itself
failed (the run then ends ``failed``, not ``aborted``). Every transition is
reported to ``on_change(previous, state, trigger, reason)`` (the supervisor
logs it). Triggers that are not valid in the current state raise
:class:`transitions.MachineError`; use :meth:`Lifecycle.can` to ask first.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import TYPE_CHECKING, NamedTuple

from transitions import EventData, Machine

if TYPE_CHECKING:  # a name of the package's type stubs only
    from transitions.core import TransitionConfigDict

STATES = ("idle", "preflight", "running", "paused", "aborting", "succeeded", "failed", "aborted")
TERMINAL = frozenset({"succeeded", "failed", "aborted"})

TRANSITIONS: list[TransitionConfigDict] = [
    {"trigger": "start", "source": "idle", "dest": "preflight"},
    {"trigger": "preflight_ok", "source": "preflight", "dest": "running"},
    {"trigger": "preflight_failed", "source": "preflight", "dest": "failed"},
    {"trigger": "pause", "source": "running", "dest": "paused"},
    {"trigger": "resume", "source": "paused", "dest": "running"},
    {"trigger": "succeed", "source": "running", "dest": "succeeded"},
    {"trigger": "fail", "source": ["running", "paused"], "dest": "failed"},
    {"trigger": "abort", "source": ["preflight", "running", "paused"], "dest": "aborting"},
    {"trigger": "abort_done", "source": "aborting", "dest": "aborted"},
    {"trigger": "end_failed", "source": "aborting", "dest": "failed"},
]

ChangeCallback = Callable[[str, str, str, str], None]


class StateChange(NamedTuple):
    """One change of state: from ``previous`` to ``state`` by ``trigger``, and why."""

    previous: str
    state: str
    trigger: str
    reason: str


class Lifecycle:
    """Supervisor lifecycle; ``state`` is one of :data:`STATES`."""

    state: str
    #: Fires a transition by its trigger's name (added by ``transitions``' ``Machine``).
    trigger: Callable[[str], bool]

    def __init__(self, on_change: ChangeCallback | None = None) -> None:
        self._on_change = on_change
        self._reason = ""
        self.history: list[StateChange] = []
        #: In a terminal state (kept by each change: the loop asks every step).
        self.finished = False
        self._machine = Machine(
            model=self,
            states=list(STATES),
            transitions=TRANSITIONS,
            initial="idle",
            auto_transitions=False,
            after_state_change="_changed",
            send_event=True,
        )

    def go(self, trigger: str, reason: str = "") -> None:
        """Fire ``trigger`` (e.g. ``"pause"``), recording ``reason`` with the change."""
        self._reason = reason
        self.trigger(trigger)

    def can(self, trigger: str) -> bool:
        return trigger in self._machine.get_triggers(self.state)

    def _changed(self, event: EventData) -> None:  # called by transitions
        transition = event.transition
        if transition is None or transition.dest is None:  # set for every change reported here
            return
        change = StateChange(transition.source, transition.dest, event.event.name, self._reason)
        self.finished = self.state in TERMINAL
        self.history.append(change)
        if self._on_change is not None:
            self._on_change(*change)
