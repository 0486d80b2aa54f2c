"""Terminal text of a replay: :func:`format_report` (exact replay or what-if)."""

from __future__ import annotations

from typing import Any

from mission.replay.compare import Divergence
from mission.replay.schema import record_steps

_COUNTED = (
    ("/supervisor/state", "lifecycle changes"),
    ("/tree", "tree status changes"),
    ("/events", "events"),
    ("/blackboard", "blackboard changes"),
    ("/kcl", "KCL reference snapshots"),
)


def _rel(report: Any, t: float) -> float:
    steps = record_steps(report.logs.original) if report.logs else []
    return t - (float(steps[0]["t"]) if steps else 0.0)


def _line(report: Any, d: Divergence) -> str:
    return f"  step {d.step:>6}  t = {_rel(report, d.t):8.2f} s  {d.describe()}"


def _header(report: Any) -> list[str]:
    speed = report.mission_s / report.wall_s if report.wall_s > 0 else float("inf")
    lines = [
        f"replay of {report.log_path}: {report.steps} steps, {report.mission_s:.1f} s of mission replayed "
        f"in {report.wall_s:.1f} s ({speed:.0f}x real time; loading {report.setup_wall_s:.1f} s, "
        f"comparison {report.compare_wall_s:.1f} s)"
    ]
    if report.log_truncated:
        lines.append(
            f"note: the log was cut short: replayed and compared up to its last complete step "
            f"({report.steps - 1 if report.ended_at_step is None else report.ended_at_step - 1})"
        )
    elif report.ended_at_step is not None:
        lines.append(f"note: the log ended (step {report.ended_at_step - 1}) before the replayed run did")
    lines += [f"note: {n}" for n in report.notes]
    if report.comparison.new_fields:
        lines.append(
            "note: this code logs fields the log does not have (not compared): "
            + ", ".join(report.comparison.new_fields)
        )
    tol = report.comparison.tolerance
    if tol > 0:
        lines.append(f"numbers compared within a relative tolerance of {tol:g} (times, decisions and text exactly)")
    return lines


def _exact(report: Any) -> list[str]:
    c = report.comparison
    lines = _header(report)
    if c.identical:
        counts = ", ".join(f"{c.counts.get(topic, 0)} {what}" for topic, what in _COUNTED)
        how = "bit for bit" if c.tolerance == 0 else "within the tolerance"
        lines.append(
            f"identical: every command and device call at each of {c.counts.get('steps', 0)} steps, and every "
            f"decision and reference ({counts}) match the log {how}"
        )
        if report.replay_outcome is not None:
            lines.append(
                f"outcome: {report.replay_outcome}" + (f" ({report.replay_cause})" if report.replay_cause else "")
            )
        return lines
    f = c.first
    lines.append(f"DIVERGED at step {f.step} (t = {_rel(report, f.t):.2f} s): {f.describe()}")
    lines.append("first difference on each channel:")
    lines += [_line(report, d) for d in c.divergences]
    lines.append(
        f"outcome: log {report.logged_outcome or 'unknown (cut short)'}, replay "
        f"{report.replay_outcome or 'unfinished (end of log)'}"
    )
    return lines


def _actions(items: list) -> str:
    return "  ".join(f"{a}@{t:.1f}s" for t, a in items) or "-"


def _whatif(report: Any) -> list[str]:
    s = report.summary or {}
    lines = _header(report)
    lines.insert(1, "what-if: " + "; ".join(report.changes))
    lines.insert(2, "note: " + s.get("open_loop", "open loop"))
    c = report.comparison
    if c.identical:
        lines.append("no difference: the change did not alter any command, device call or decision")
        return lines
    f = c.first
    lines.append(f"first difference at step {f.step} (t = {_rel(report, f.t):.2f} s): {f.describe()}")
    lines.append("first difference on each channel:")
    lines += [_line(report, d) for d in c.divergences]
    for call, title in (
        ("arm.command_joint_velocity", "joint references (rad/s)"),
        ("vehicle.command_body_velocity", "vehicle references (m/s, rad/s)"),
    ):
        cs = s.get("commands", {}).get(call)
        if cs is None:
            continue
        if not cs["steps_different"]:
            lines.append(f"{title}: identical at all {cs['steps_compared']} steps")
            continue
        lines.append(
            f"{title}: different at {cs['steps_different']} of {cs['steps_compared']} steps, from "
            f"t = {cs['first_different_t_s']:.2f} s"
        )
        lines.append(f"    {'':<20} {'max |diff|':>11} {'at t [s]':>9} {'rms diff':>10} {'rms logged':>11}")
        for i, name in enumerate(cs["dofs"]):
            lines.append(
                f"    {name:<20} {cs['max_abs_diff'][i]:11.4g} {cs['t_of_max_s'][i]:9.2f} "
                f"{cs['rms_diff'][i]:10.4g} {cs['rms_logged'][i]:11.4g}"
            )
    acts, states = s.get("actions", {}), s.get("states", {})
    if acts.get("log") == acts.get("replay"):
        lines.append(f"actions started: same as the log ({_actions(acts.get('log', []))})")
    else:
        lines.append(
            f"actions started:\n    log:     {_actions(acts.get('log', []))}\n    what-if: {_actions(acts.get('replay', []))}"
        )
    if states.get("log") != states.get("replay"):
        lines.append(
            f"lifecycle:\n    log:     {_actions(states.get('log', []))}\n    what-if: {_actions(states.get('replay', []))}"
        )
    lines.append(
        f"outcome: log {report.logged_outcome or 'unknown (cut short)'}, what-if "
        f"{report.replay_outcome or 'unfinished when the log ended'}"
        + (f" ({report.replay_cause})" if report.replay_cause else "")
    )
    for side, title in (("log", "events only in the log"), ("replay", "events only in the what-if")):
        evs = s.get("events_only_in", {}).get(side, [])
        if evs:
            lines.append(f"{title} ({len(evs)}):")
            lines += [f"    {t:8.2f} s  {k}: {m}" for t, k, m in evs[:8]]
            if len(evs) > 8:
                lines.append(f"    ... and {len(evs) - 8} more")
    return lines


def format_report(report: Any) -> str:
    """Text for the terminal."""
    return "\n".join(_whatif(report) if report.whatif else _exact(report))


def report_dict(report: Any) -> dict:
    """JSON-able report (``maris log replay --json``)."""
    c = report.comparison

    def div(d: Divergence) -> dict:
        return {
            "step": d.step,
            "t_s": _rel(report, d.t),
            "channel": d.channel,
            "what": d.what,
            "logged": d.logged,
            "replay": d.replay,
        }

    return {
        "log": str(report.log_path),
        "whatif": report.whatif,
        "changes": report.changes,
        "notes": report.notes,
        "new_fields": c.new_fields,
        "identical": c.identical,
        "tolerance": c.tolerance,
        "first_divergence": div(c.first) if c.first else None,
        "divergences": [div(d) for d in c.divergences],
        "compared": c.counts,
        "logged_outcome": report.logged_outcome,
        "replay_outcome": report.replay_outcome,
        "replay_failure_cause": report.replay_cause,
        "log_truncated": report.log_truncated,
        "ended_at_step": report.ended_at_step,
        "steps": report.steps,
        "mission_s": report.mission_s,
        "wall_s": report.wall_s,
        "setup_wall_s": report.setup_wall_s,
        "compare_wall_s": report.compare_wall_s,
        "replay_log": str(report.replay_log) if report.replay_log else None,
        "summary": report.summary,
    }
