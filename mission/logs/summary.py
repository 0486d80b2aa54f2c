"""What happened in a run, from its log: outcome, duration, action timeline,
grasp result, closest approach to each safety limit, faults.

:func:`summarize` is pure (a :class:`RunLog` in, a JSON-able dict out);
:func:`format_summary` renders it for the terminal (``maris log summary`` and
the end of ``maris sim``).
"""

from __future__ import annotations

import math

from mission.logs.reader import RunLog


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


def closest_margins(log: RunLog) -> dict[str, dict]:
    """Per safety limit: smallest margin seen and when (s since the run start).

    The logged margins are sampled at the KCL log rate; the run result's
    ``closest_to_limits`` (every base step) wins where present, so this agrees
    with the summary printed at the end of the run."""
    best: dict[str, dict] = {}
    t0 = log.t0
    for m in log.messages("/safety/margins"):
        for name, value in (m.get("margins") or {}).items():
            if value is None:
                continue
            if name not in best or value < best[name]["margin"]:
                best[name] = {"margin": float(value), "t": float(m["t"]) - t0}
    metrics = (log.result or {}).get("metrics") or {}
    times = metrics.get("closest_to_limits_t") or {}
    for name, value in (metrics.get("closest_to_limits") or {}).items():
        if value is not None and times.get(name) is not None:
            best[name] = {"margin": float(value), "t": float(times[name])}
    return best


def summarize(log: RunLog) -> dict:
    """JSON-able summary of one run log."""
    result = log.result or {}
    gt = log.messages("/ground_truth")
    distances = [m["tool_to_target_m"] for m in gt if m.get("tool_to_target_m") is not None]
    t0 = log.t0
    faults = [
        {"t": m["t"] - t0, "kind": m.get("kind", ""), "message": m.get("message", "")}
        for m in log.messages("/events")
        if m.get("level") == "fault"
    ]
    warnings = [
        {"t": m["t"] - t0, "kind": m.get("kind", ""), "message": m.get("message", "")}
        for m in log.messages("/events")
        if m.get("level") == "warning" and (m.get("fields") or {}).get("summary")
    ]
    states = [(m["t"] - t0, m.get("state")) for m in log.messages("/supervisor/state")]
    grasp = result.get("grasp")
    if grasp is None and gt:
        grasp = gt[-1].get("grasp")
    metrics = result.get("metrics") or {}
    # the result's figures include the final ground truth taken after the last log sample
    min_d = metrics.get("min_tool_to_target_m")
    final_d = metrics.get("final_tool_to_target_m")
    if min_d is None and distances:
        min_d = min(distances)
    if final_d is None and distances:
        final_d = distances[-1]
    return {
        "path": str(log.path),
        "outcome": result.get("outcome") or ("incomplete (log cut short)" if log.truncated else "unknown"),
        "failure_cause": result.get("failure_cause"),
        "duration_s": float(result.get("duration_s", log.end_time)),
        "truncated": log.truncated,
        "actions": action_timeline(log),
        "supervisor_states": states,
        "grasp": grasp,
        "min_tool_to_target_m": min_d,
        "final_tool_to_target_m": final_d,
        "closest_to_limits": closest_margins(log),
        "faults": faults,
        "warnings": warnings,
        "event_count": len(log.messages("/events")),
        "metrics": metrics,
    }


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
        lines.append(f"faults ({len(s['faults'])}):")
        for f in s["faults"][:10]:
            lines.append(f"  {f['t']:8.2f} s  {f['kind']}: {f['message']}")
    return "\n".join(lines)
