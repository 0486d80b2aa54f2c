"""The run's base steps: their index and the backend's advance by one.

The loop runs one base step per arm KCL period (``dt`` s of the backend clock);
the schedule's slower jobs are due by the step index. The loop and the settle
period after a stop (:class:`mission.runtime.endings.SafeStop`) both move it on.
"""

from __future__ import annotations

from hal.interfaces import Backend
from mission.runtime.schedule import Schedule


class BaseSteps:
    """The index of the current base step and the backend it advances."""

    def __init__(self, backend: Backend, schedule: Schedule) -> None:
        self.backend = backend
        self.schedule = schedule
        #: Base period, s.
        self.dt = schedule.dt
        #: Index of the current base step (0 at the loop's start).
        self.index = 0

    def due(self, job: str) -> bool:
        """Whether the schedule's ``job`` runs at the current step."""
        return self.schedule.due(job, self.index)

    def advance(self) -> None:
        """Let the backend run one base step and move to the next."""
        self.backend.advance(self.dt)
        self.index += 1
