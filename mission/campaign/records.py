"""The outcome of one run of a campaign, as stored in tables and CSV files.

Outcome names (``RunRecord.outcome``):

* ``success`` - the object was grasped (and the mission finished).
* ``not_detected`` - the vision never found the target (during the survey,
  or during every grasp attempt).
* ``grasp_missed`` - the target was found but the gripper closed on nothing,
  or the grasp slipped / the tool never converged to the grasp pose.
* ``timeout`` - the mission ran out of (simulated) time.
* ``abort`` - the supervisor or a safety monitor stopped the mission.
* ``error`` - the run raised: a software fault, recorded with its traceback.

``RunRecord.attempts`` lists the run's grasp attempts (dicts of
:class:`mission.campaign.attempts.Attempt`): the paper scores attempts, the
outcome above scores the mission.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass, field
from typing import Any

OUTCOMES: tuple[str, ...] = ("success", "not_detected", "grasp_missed", "timeout", "abort", "error")
FAILURE_OUTCOMES: tuple[str, ...] = OUTCOMES[1:]


@dataclass
class RunRecord:
    """One run's result. Times in seconds; ``duration_s`` is simulated time,
    ``wall_s`` the wall-clock time the run took (not part of tables/CSV, so that
    re-running a campaign gives identical files)."""

    index: int
    seed: int
    outcome: str
    duration_s: float = float("nan")
    failure_cause: str | None = None
    grasp: str | None = None
    metrics: dict[str, float] = field(default_factory=dict)
    error: str | None = None
    traceback: str | None = None
    log_path: str | None = None
    wall_s: float = float("nan")
    attempts: list[dict] = field(default_factory=list)

    @property
    def success(self) -> bool:
        return self.outcome == "success"

    def to_dict(self) -> dict[str, Any]:
        return asdict(self)
