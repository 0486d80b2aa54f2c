"""What happened in a run, from its log: outcome, duration, action timeline,
grasp result, closest approach to each safety limit, faults.

:func:`summarize` is pure (a :class:`RunLog` in, a JSON-able dict out);
:func:`summarize_file` gives the same dict streaming the file (``maris log
summary``: memory stays flat however long the log); both feed
:class:`SummaryBuilder`. :func:`format_summary` renders it for the terminal
(``maris log summary`` and the end of ``maris sim``).
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import NamedTuple

from mission.logs.reader import RunLog
from mission.logs.stream import LogStream


def action_timeline(log: RunLog) -> list[tuple[float, str]]:
    """``(start time s since the run start, action)`` each time the KCL's current action changed."""
    out: list[tuple[float, str]] = []
    last = object()
    t0 = log.t0
    for m in log.messages("/kcl"):
        a = m.get("action")
        if a != last:
            if a is not None:
                out.append((float(m["t"]) - t0, str(a)))
            last = a
    return out


class Closest(NamedTuple):
    """The smallest margin to a limit seen in a log, and when (log time, s)."""

    margin: float
    t: float


def closest_margins(log: RunLog) -> dict[str, dict]:
    """Per safety limit: smallest margin seen and when (s since the run start).

    The logged margins are sampled at the KCL log rate; the run result's
    ``closest_to_limits`` (every base step) wins where present, so this agrees
    with the summary printed at the end of the run."""
    b = SummaryBuilder()
    for m in log.messages("/safety/margins"):
        b.add("/safety/margins", m)
    b.add("/run/config", {"t": log.t0})
    if log.result is not None:
        b.add("/run/result", log.result)
    return b.closest(log.t0)


#: Fault events kept in a summary (the count is always complete).
MAX_FAULTS = 200
#: The topics a summary reads.
TOPICS = ("/kcl", "/safety/margins", "/ground_truth", "/events", "/supervisor/state", "/run/config", "/run/result")


class SummaryBuilder:
    """Builds :func:`summarize`'s dict from messages fed one at a time
    (:meth:`add`), in constant memory: per topic only running figures are kept
    (the action switches, the supervisor states and the first
    :data:`MAX_FAULTS` fault events grow with the run's events, not its length)."""

    def __init__(self) -> None:
        self.t_config: float | None = None
        self.t_first: float | None = None
        self.t_last: float | None = None
        self.result: dict | None = None
        self.switches: list[tuple[float, str]] = []
        self._action: object = object()
        self.margins: dict[str, Closest] = {}
        self.min_d: float | None = None
        self.last_d: float | None = None
        self.last_grasp: object = None
        self.truth_seen = False
        self.faults: list[dict] = []
        self.fault_count = 0
        self.warnings: list[dict] = []  # warning events flagged for the summary (fields.summary)
        self.event_count = 0
        self.states: list[tuple[float, object]] = []

    def add(self, topic: str, m: dict) -> None:
        """Take one message of ``topic``."""
        stamp = m.get("t")
        if not isinstance(stamp, (int, float)):
            return  # every message of a run log has its time (mission.logs.writer): not one of those
        t = float(stamp)
        self.t_first = t if self.t_first is None else min(self.t_first, t)
        self.t_last = t if self.t_last is None else max(self.t_last, t)
        if topic == "/kcl":
            a = m.get("action")
            if a != self._action:
                if a is not None:
                    self.switches.append((t, str(a)))
                self._action = a
        elif topic == "/safety/margins":
            for name, value in (m.get("margins") or {}).items():
                if value is not None and (name not in self.margins or value < self.margins[name].margin):
                    self.margins[name] = Closest(float(value), t)
        elif topic == "/ground_truth":
            self.truth_seen = True
            self.last_grasp = m.get("grasp")
            d = m.get("tool_to_target_m")
            if d is not None:
                self.last_d = d
                self.min_d = d if self.min_d is None else min(self.min_d, d)
        elif topic == "/events":
            self.event_count += 1
            if m.get("level") == "fault":
                self.fault_count += 1
                if len(self.faults) < MAX_FAULTS:
                    self.faults.append({"t": t, "kind": m.get("kind", ""), "message": m.get("message", "")})
            elif (
                m.get("level") == "warning"
                and (m.get("fields") or {}).get("summary")
                and len(self.warnings) < MAX_FAULTS
            ):
                self.warnings.append({"t": t, "kind": m.get("kind", ""), "message": m.get("message", "")})
        elif topic == "/supervisor/state":
            self.states.append((t, m.get("state")))
        elif topic == "/run/config" and self.t_config is None:
            self.t_config = t
        elif topic == "/run/result":
            self.result = m

    @property
    def t0(self) -> float:
        """Backend time (s) of the run start (its ``/run/config``), else the first message's."""
        return self.t_config if self.t_config is not None else (self.t_first or 0.0)

    def closest(self, t0: float) -> dict[str, dict]:
        best = {name: {"margin": v, "t": t - t0} for name, (v, t) in self.margins.items()}
        metrics = (self.result or {}).get("metrics") or {}
        times = metrics.get("closest_to_limits_t") or {}
        for name, value in (metrics.get("closest_to_limits") or {}).items():
            if value is not None and times.get(name) is not None:
                best[name] = {"margin": float(value), "t": float(times[name])}
        return best

    def summary(self, path: object, truncated: bool) -> dict:
        """The summary dict (see :func:`summarize`)."""
        result = self.result or {}
        t0 = self.t0
        grasp = result.get("grasp")
        if grasp is None and self.truth_seen:
            grasp = self.last_grasp
        metrics = result.get("metrics") or {}
        # the result's figures include the final ground truth taken after the last log sample
        min_d = metrics.get("min_tool_to_target_m")
        final_d = metrics.get("final_tool_to_target_m")
        if min_d is None:
            min_d = self.min_d
        if final_d is None:
            final_d = self.last_d
        end = (self.t_last - t0) if self.t_last is not None else 0.0
        return {
            "path": str(path),
            "outcome": result.get("outcome") or ("incomplete (log cut short)" if truncated else "unknown"),
            "failure_cause": result.get("failure_cause"),
            "duration_s": float(result.get("duration_s", end)),
            "truncated": truncated,
            "actions": [(t - t0, a) for t, a in self.switches],
            "supervisor_states": [(t - t0, st) for t, st in self.states],
            "grasp": grasp,
            "min_tool_to_target_m": min_d,
            "final_tool_to_target_m": final_d,
            "closest_to_limits": self.closest(t0),
            "faults": [{**f, "t": f["t"] - t0} for f in self.faults],
            "fault_events": self.fault_count,
            "warnings": [{**w, "t": w["t"] - t0} for w in self.warnings],
            "event_count": self.event_count,
            "metrics": metrics,
        }


def summarize(log: RunLog) -> dict:
    """JSON-able summary of one run log already read into memory."""
    b = SummaryBuilder()
    for topic, msgs in log.topics.items():
        for m in msgs:
            b.add(topic, m)
    return b.summary(log.path, log.truncated)


def summarize_file(path: str | Path) -> tuple[dict, LogStream]:
    """:func:`summarize` of the log at ``path``, streamed: memory does not grow with the
    log's length. Returns the summary and the finished stream (``truncated``,
    ``stop_reason``). Raises :class:`mission.logs.reader.LogError` for non-logs."""
    stream = LogStream(path, TOPICS)
    b = SummaryBuilder()
    for topic, m in stream:
        b.add(topic, m)
    if stream.last_time is not None:  # the end of the log, from every topic's log times
        b.t_last = stream.last_time if b.t_last is None else max(b.t_last, stream.last_time)
    return b.summary(stream.path, stream.truncated), stream


def _fmt(x: object, unit: str = "", digits: int = 3) -> str:
    if x is None:
        return "n/a"
    if isinstance(x, float):
        return ("n/a" if not math.isfinite(x) else f"{x:.{digits}f}") + unit
    return f"{x}{unit}"


def format_summary(s: dict) -> str:
    """Human-readable multi-line rendering of :func:`summarize`'s dict."""
    lines = [f"outcome:   {s['outcome']}" + (f"  ({s['failure_cause']})" if s.get("failure_cause") else "")]
    lines.append(f"duration:  {_fmt(s['duration_s'], ' s', 1)}" + ("   [log cut short]" if s.get("truncated") else ""))
    if s["actions"]:
        lines.append("actions:   " + "  ->  ".join(f"{a} @ {t:.1f} s" for t, a in s["actions"]))
    else:
        lines.append("actions:   none")
    lines.append(
        f"grasp:     {s['grasp'] or 'n/a'}   tool-to-target min {_fmt(s['min_tool_to_target_m'], ' m')}, "
        f"final {_fmt(s['final_tool_to_target_m'], ' m')}"
    )
    if s["closest_to_limits"]:
        lines.append("closest approach to limits (margin, time):")
        for name, v in sorted(s["closest_to_limits"].items()):
            lines.append(f"  {name:<22} {v['margin']:9.3f}   at {v['t']:.1f} s")
    if s.get("warnings"):  # things the outcome alone does not tell (e.g. an altitude floor not enforced)
        lines.append(f"warnings ({len(s['warnings'])}):")
        for w in s["warnings"][:10]:
            lines.append(f"  {w['t']:8.2f} s  {w['kind']}: {w['message']}")
    if s["faults"]:
        lines.append(f"faults ({s.get('fault_events', len(s['faults']))}):")
        for f in s["faults"][:10]:
            lines.append(f"  {f['t']:8.2f} s  {f['kind']}: {f['message']}")
    return "\n".join(lines)
