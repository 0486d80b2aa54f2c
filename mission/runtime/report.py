"""Final run summary for the terminal, from a :class:`RunResult` (same layout as
``maris log summary``)."""

from __future__ import annotations

from mission.logs.summary import format_summary
from mission.runtime.supervisor import RunResult


def result_summary(result: RunResult) -> dict:
    """The :func:`mission.logs.summary.summarize` dict shape, built from a result."""
    m = result.metrics
    return {
        "path": result.log_path,
        "outcome": result.outcome,
        "failure_cause": result.failure_cause,
        "duration_s": result.duration_s,
        "truncated": False,
        "actions": result.actions,
        "grasp": result.grasp,
        "min_tool_to_target_m": m.get("min_tool_to_target_m"),
        "final_tool_to_target_m": m.get("final_tool_to_target_m"),
        "closest_to_limits": {
            k: {"margin": v, "t": m.get("closest_to_limits_t", {}).get(k, float("nan"))}
            for k, v in m.get("closest_to_limits", {}).items()
        },
        "faults": [
            {"t": e.t - m.get("t0", 0.0), "kind": e.kind, "message": e.message}
            for e in result.events
            if e.level == "fault"
        ],
        "warnings": [
            {"t": e.t - m.get("t0", 0.0), "kind": e.kind, "message": e.message}
            for e in result.events
            if e.level == "warning" and e.fields.get("summary")
        ],
        "metrics": m,
    }


def describe_step(entry: dict) -> str:
    """One line of a ``wall_slowest_steps`` entry: when, how long, its largest phases."""
    phases = sorted(entry["phases_s"].items(), key=lambda kv: -kv[1])
    parts = ", ".join(f"{name} {1e3 * sec:.1f}" for name, sec in phases[:3])
    cpu = entry.get("cpu_s")
    cpu_text = "" if cpu is None else f"; loop thread CPU {1e3 * cpu:.1f} ms"
    kind = "tree step" if entry.get("tree_step") else "step"
    return f"{kind} {entry['step']} at {entry['t']:.2f} s took {1e3 * entry['work_s']:.1f} ms ({parts} ms{cpu_text})"


def format_result(result: RunResult) -> str:
    """Multi-line summary: outcome, duration, actions, grasp, closest approach to limits, faults."""
    text = format_summary(result_summary(result)).replace("   at nan s", "")
    extra = []
    rf = result.metrics.get("realtime_factor")
    if rf:
        extra.append(f"speed:     {rf:.1f}x real time ({result.metrics.get('wall_s', 0):.1f} s wall)")
    overruns = result.metrics.get("wall_overrun_steps")
    if overruns and result.metrics.get("realtime"):  # lockstep runs have no deadline to miss
        extra.append(
            f"timing:    {overruns} loop steps took longer than the base period "
            f"(longest {1000 * result.metrics.get('wall_max_step_s', 0):.1f} ms)"
        )
        slowest = result.metrics.get("wall_slowest_steps") or []
        if slowest:
            extra.append("slowest:   " + describe_step(slowest[0]))
    work = result.metrics.get("wall_step_work") or {}
    if result.metrics.get("realtime") and work.get("steps"):
        ticks = result.metrics.get("wall_ticks") or {}
        extra.append(
            f"loop:      step work p50 {1e3 * work['p50_s']:.2f} / p99 {1e3 * work['p99_s']:.2f} / "
            f"max {1e3 * work['max_s']:.2f} ms over {work['steps']} steps; "
            f"{ticks.get('missed', 0)} ticks reached late"
        )
        imports = result.metrics.get("loop_imports") or []
        if imports:  # each stalled a step: a lazy import on the loop's path (a bug to report)
            extra.append(f"imports:   {len(imports)} modules first imported inside the loop: {', '.join(imports)}")
    if result.log_path:
        extra.append(f"log:       {result.log_path}")
    return "\n".join([text, *extra])
