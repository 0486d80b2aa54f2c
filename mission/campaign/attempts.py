"""Grasp attempts of one run and why each ended (pure functions of its events).

The MARIS paper (Table I) counts grasp *attempts*, not missions: a mission may
try several times. Here an attempt is one run of the KCL ``grasp`` action (an
``action_start`` event with ``action == "grasp"``), up to the next one or the
end of the run; what happened in that window decides its outcome, in order:

* ``success``: the simulator says the hand closed around the pipe (a ``grasp``
  event of the simulator) and the attempt was not failed afterwards;
* ``slip``: the hand touched the pipe off its tolerances and it squirted out
  (the simulator's ``slip`` event);
* ``not_detected``: the reach timed out without ever getting a detection taken
  during the attempt (no ``target_acquired`` event): nothing to converge to;
* ``no_convergence``: the reach timed out with a target: the tool never settled
  on the grasp pose (the paper's failure);
* ``closed_on_nothing``: the controller reported the grasp pose reached, the
  hand closed, but around no pipe (navigation or vision error);
* ``gripper``: the gripper failed (fault or time-out) during the attempt;
* ``abort``: the run stopped (safety, operator, time limit) during the attempt.

Each attempt also records ``duration_s`` (from its start to its end, s) and,
for a success, ``time_to_grasp_s`` (from its start to the hand closing on the pipe).
When the fingers touched the pipe (a simulator ``grasp`` or ``slip`` event),
``contact`` holds where the pipe's axis was in the hand then (m, tool frame:
``across_m``, ``approach_m``; ``position_error_m`` to the true grasp frame).
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from typing import Any

#: Attempt outcomes, success first (see the module docstring).
ATTEMPT_OUTCOMES: tuple[str, ...] = (
    "success",
    "no_convergence",
    "slip",
    "closed_on_nothing",
    "not_detected",
    "gripper",
    "abort",
)
ATTEMPT_FAILURES: tuple[str, ...] = ATTEMPT_OUTCOMES[1:]
GRASP_ACTION = "grasp"


@dataclass(frozen=True)
class Attempt:
    """One grasp attempt: ``outcome`` (:data:`ATTEMPT_OUTCOMES`), start time (s,
    backend clock), duration (s), time to grasp (s, successes only)."""

    outcome: str
    t_start: float
    duration_s: float
    time_to_grasp_s: float | None = None
    contact: dict | None = None

    def to_dict(self) -> dict:
        out = {
            "outcome": self.outcome,
            "t_start": self.t_start,
            "duration_s": self.duration_s,
            "time_to_grasp_s": self.time_to_grasp_s,
        }
        if self.contact is not None:
            out["contact"] = self.contact
        return out


#: fields of the simulator's grasp / slip event kept in ``Attempt.contact`` (relayed with a ``sim_`` prefix)
CONTACT_FIELDS = ("across_m", "approach_m", "position_error_m")


def _contact(window: list[Any]) -> dict | None:
    """Where the pipe was in the hand at the first finger contact of the window, or None."""
    for ev in window:
        if _sim_event(ev) in ("grasp", "slip"):
            out = {}
            for name in CONTACT_FIELDS:
                v = _get(ev, "sim_" + name, _get(ev, name))
                if isinstance(v, (int, float)):
                    out[name] = float(v)
            return out or None
    return None


def _get(ev: Any, name: str, default: Any = None) -> Any:
    if isinstance(ev, dict):
        if name in ("t", "kind", "message"):
            return ev.get(name, default)
        return ev.get("fields", ev).get(name, default)
    if name in ("t", "kind", "message"):
        return getattr(ev, name, default)
    return (getattr(ev, "fields", None) or {}).get(name, default)


def _sim_event(ev: Any) -> str | None:
    """Name of a simulator event relayed by the supervisor (``"simulator: grasp"``), else None."""
    if _get(ev, "kind") != "sim":
        return None
    msg = str(_get(ev, "message") or "")
    return msg.split(":", 1)[1].strip() if ":" in msg else None


def split_attempts(events: Sequence[Any], t_end: float) -> list[tuple[float, float, list[Any]]]:
    """``(t_start, t_stop, events)`` windows, one per start of the grasp action."""
    starts = [
        i for i, ev in enumerate(events) if _get(ev, "kind") == "action_start" and _get(ev, "action") == GRASP_ACTION
    ]
    out = []
    for k, i in enumerate(starts):
        j = starts[k + 1] if k + 1 < len(starts) else len(events)
        t0 = float(_get(events[i], "t"))
        t1 = float(_get(events[j], "t")) if j < len(events) else float(t_end)
        out.append((t0, t1, list(events[i:j])))
    return out


def classify_attempt(window: Iterable[Any], t_start: float, t_stop: float, run_ended_here: bool) -> Attempt:
    """Outcome of one attempt from the events of its window (see the module docstring).
    ``run_ended_here``: the run stopped inside this window (last attempt)."""
    window = list(window)
    sims = [(float(_get(e, "t")), _sim_event(e)) for e in window if _sim_event(e)]
    kinds = [_get(e, "kind") for e in window]
    failed = "attempt_failed" in kinds
    grasp_t = next((t for t, name in sims if name == "grasp"), None)
    duration = max(0.0, t_stop - t_start)
    contact = _contact(window)
    if grasp_t is not None and not failed:
        return Attempt("success", t_start, duration, grasp_t - t_start, contact)
    if any(name == "slip" for _, name in sims):
        return Attempt("slip", t_start, duration, contact=contact)
    reach_timeout = any(
        _get(e, "kind") == "action_failure"
        and _get(e, "action") == GRASP_ACTION
        and "timed out" in str(_get(e, "message") or "")
        for e in window
    )
    if reach_timeout:
        outcome = "no_convergence" if "target_acquired" in kinds else "not_detected"
        return Attempt(outcome, t_start, duration)
    if "gripper_error" in kinds or any(
        _get(e, "kind") == "timeout" and "gripper" in str(_get(e, "message") or "") for e in window
    ):
        return Attempt("gripper", t_start, duration)
    if failed:
        closed = any(_get(e, "kind") == "gripper_command" and "close" in str(_get(e, "message") or "") for e in window)
        if closed:
            return Attempt("closed_on_nothing", t_start, duration)
        return Attempt("abort", t_start, duration)
    if grasp_t is not None:  # grasped, then failed otherwise (confirmation): count what the hand did
        return Attempt("success", t_start, duration, grasp_t - t_start, contact)
    return Attempt("abort" if run_ended_here else "closed_on_nothing", t_start, duration)


def attempts_of_run(events: Sequence[Any], t_end: float) -> list[Attempt]:
    """Every grasp attempt of a run, in order (events as ``mission.runtime`` Event
    objects or their dict form; ``t_end``: backend time the run ended, s)."""
    windows = split_attempts(events, t_end)
    return [classify_attempt(w, t0, t1, k == len(windows) - 1) for k, (t0, t1, w) in enumerate(windows)]
