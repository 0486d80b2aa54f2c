"""Failure-cause classification of one run (pure function of its RunResult).

The supervisor reports ``outcome`` (succeeded / failed / aborted), a free-text
``failure_cause``, the simulator's ``grasp`` truth and the KCL actions entered
(``actions``: ``(t, name)``). A campaign needs coarse, stable categories
(:data:`mission.campaign.records.OUTCOMES`); the rules, in order:

1. succeeded, and the gripper holds the object when a grasp was attempted
   -> ``success`` (succeeded but the truth says nothing is held -> ``grasp_missed``);
2. the mission duration limit or the run time cap -> ``timeout``;
3. a safety breach (watchdog, envelope, drive fault, NaN), an operator stop,
   a preflight failure or an internal error -> ``abort``;
4. the mission failed during the survey (``survey`` entered, ``grasp``
   never) -> the target was never detected -> ``not_detected``;
5. the mission failed before any survey or grasp (e.g. stowing the arm at
   the start) -> ``abort``;
6. otherwise (reach did not converge, gripper closed on nothing, grasp not
   confirmed after the retries) -> ``grasp_missed``.
"""

from __future__ import annotations

from typing import Any

GRASP_ACTION = "grasp"
SURVEY_ACTION = "survey"
_TIMEOUT_MARKS = ("mission duration limit", "run time cap", "duration_s")
_ABORT_MARKS = (
    "watchdog",
    "envelope",
    "drive_fault",
    "non_finite",
    "vehicle_link",
    "sensor_lost",
    "operator",
    "preflight",
    "internal error",
    "safe stop",
)


def classify(result: Any) -> str:
    """Outcome category of a ``mission.runtime`` RunResult (see module doc)."""
    actions = {name for _t, name in (getattr(result, "actions", None) or [])}
    grasp_tried = GRASP_ACTION in actions
    grasp = getattr(result, "grasp", None)
    if result.outcome == "succeeded":
        if grasp_tried and grasp not in (None, "holding"):
            return "grasp_missed"
        return "success"
    cause = (getattr(result, "failure_cause", None) or "").lower()
    if any(m in cause for m in _TIMEOUT_MARKS):
        return "timeout"
    if any(m in cause for m in _ABORT_MARKS):
        return "abort"
    if not grasp_tried:
        return "not_detected" if SURVEY_ACTION in actions else "abort"
    return "grasp_missed"
