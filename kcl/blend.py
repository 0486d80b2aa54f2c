"""The current action and the smooth transition between actions (MARIS eq. 13).

Actions are subsets of one unified hierarchy (:mod:`kcl.actions`), so an action
switch never rebuilds anything: each task's action-transition factor ``a_p``
moves from its value at the switch to 1 (task in the new action) or 0 (not in
it) along an increasing bell over the file's ``transition_time``, and the
controller multiplies the task's activation by it. :class:`ActionBlend` holds
that state and gives the factors of every task at a time, in hierarchy order.
"""

from __future__ import annotations

import numpy as np

from kcl.actions import ActionSet
from kcl.activation import increasing_bell


class ActionBlend:
    """Action-transition factors of the tasks of ``actions`` (hierarchy order).

    ``set_action(name, t)`` starts a transition at ``t`` (s); ``stop()`` makes the
    next ``set_action`` fade the action in from zero; :meth:`factors_at` gives the
    factors (an array that stays the same object while no transition runs)."""

    def __init__(self, actions: ActionSet):
        self.actions = actions
        #: task names, hierarchy order (the order of :meth:`factors_at`)
        self.names: tuple[str, ...] = tuple(t.name for lv in actions.levels for t in lv.tasks)
        self.transition_time = float(actions.transition_time)
        self.action: str | None = None
        self.previous_action: str | None = None
        self.stopped = True
        self.t_switch = 0.0
        self._start = np.zeros(len(self.names))
        self._end = np.zeros(len(self.names))
        self._now = self._end

    def __copy__(self) -> ActionBlend:
        """A shallow copy (the telemetry snapshot's): the blend replaces its arrays
        at a switch and never writes into them."""
        twin = object.__new__(ActionBlend)
        twin.__dict__.update(self.__dict__)
        return twin

    def set_action(self, name: str, t: float) -> None:
        """Make ``name`` the current action at ``t`` (s): its tasks fade in, the
        others out. The same action again changes nothing, except after
        :meth:`stop` (it then fades back in from zero). KeyError for an unknown name."""
        wanted = set(self.actions.tasks_of(name))
        if name == self.action and not self.stopped:
            return
        self._start = np.zeros(len(self.names)) if self.stopped else self.factors_at(t).copy()
        self._end = np.array([1.0 if n in wanted else 0.0 for n in self.names])
        if name != self.action:
            self.previous_action = self.action
        self.action = name
        self.t_switch = float(t)
        self.stopped = False

    def stop(self) -> None:
        """The controller stops: the next :meth:`set_action` starts from zero."""
        self.stopped = True

    def in_transition(self, t: float) -> bool:
        """Whether factors still move at ``t`` (s)."""
        return t - self.t_switch < self.transition_time

    def factors_at(self, t: float) -> np.ndarray:
        """a_p of every task at ``t`` (s), hierarchy order: ``start + (end -
        start) * IncreasingBell(t - t_switch; 0, T)``, the end values themselves
        (the same array object) once the transition is over. Do not modify."""
        if not self.in_transition(t):
            return self._end
        b = increasing_bell(t - self.t_switch, 0.0, self.transition_time)
        self._now = self._start + (self._end - self._start) * b
        return self._now

    def factor(self, name: str, t: float) -> float:
        """a_p of task ``name`` at ``t`` (s)."""
        return float(self.factors_at(t)[self.names.index(name)])

    def progress(self, t: float) -> float:
        """0 at an action switch, 1 once the transition time has passed."""
        T = self.transition_time
        if T <= 0.0:
            return 1.0
        return float(min(1.0, max(0.0, (t - self.t_switch) / T)))
