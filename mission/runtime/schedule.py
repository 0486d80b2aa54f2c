"""Multi-rate scheduling on one base clock.

The loop runs at the fastest rate (the arm KCL); slower jobs (vehicle KCL, tree
tick, logging) run every ``divider`` base steps. Dividers are rounded, so the
effective rate is ``base_hz / divider``; :func:`make_schedule` reports it.
"""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class Job:
    name: str
    divider: int
    #: Base step (0-based, within a divider period) at which this job runs.
    phase: int = 0

    def due(self, step: int) -> bool:
        return step % self.divider == self.phase


@dataclass(frozen=True)
class Schedule:
    base_hz: float
    jobs: dict[str, Job]

    @property
    def dt(self) -> float:
        """Base step, s."""
        return 1.0 / self.base_hz

    def rate(self, name: str) -> float:
        """Effective rate of a job, Hz."""
        return self.base_hz / self.jobs[name].divider

    def due(self, name: str, step: int) -> bool:
        return self.jobs[name].due(step)


def make_schedule(base_hz: float, rates_hz: dict[str, float], offsets: dict[str, float] | None = None) -> Schedule:
    """Schedule with each job as close to its requested rate as the base allows
    (never faster than the base). ``offsets``: for some jobs, where in their own
    period they run (fraction 0..1 of it, rounded down to a base step; default 0,
    the period's first step), so that slow jobs spread over the base steps instead
    of all landing on the same one. Raises ValueError on non-positive rates."""
    if not base_hz > 0:
        raise ValueError(f"base rate must be positive, got {base_hz}")
    offsets = offsets or {}
    jobs = {}
    for name, hz in rates_hz.items():
        if not hz > 0:
            raise ValueError(f"rate of {name} must be positive, got {hz}")
        divider = max(1, round(base_hz / hz))
        jobs[name] = Job(name, divider, int(offsets.get(name, 0.0) * divider) % divider)
    return Schedule(base_hz, jobs)
