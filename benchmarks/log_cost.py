"""What each part of the run log costs a dry run, by leaving it out: wall us per 10 ms step.

Runs the reference mission on the simulator (lockstep, as ``benchmarks/dry_run.py``)
in several configurations, each in a fresh process, the configurations
alternated round after round (a busy host's slow phases then fall on all of
them alike), and prints per configuration the median and range over the rounds
of the supervisor loop's wall time per base step. The configurations use only
the runtime's own knobs (``run_mission``'s ``record_inputs`` and the log rates
of :class:`mission.runtime.result.SupervisorOptions`); a part left out is
written at most once, at the start of the run, instead of at its rate:

* ``full``: the log as ``maris sim`` writes it (input record, device log 20 Hz,
  3D view 10 Hz, ground truth 10 Hz, KCL telemetry 10 Hz, tree, events);
* ``-input_record``, ``-device_log``, ``-3d_view``, ``-ground_truth``, ``-kcl``:
  ``full`` without that part;
* ``log_skeleton``: all five left out (what stays: tree, blackboard, health,
  events, state changes, the result);
* ``no_log``: no log at all (``--no-log`` of ``dry_run.py``).

A part's cost is the median over the rounds of ``full`` minus the run without
it in the same round (the range is printed: on a busy host a part smaller than
the spread needs more rounds to show); "if free" is
the real-time factor ``full`` would have were that part free (an upper bound of
what any change to that part alone can give). The ground truth is one job: left
out, its sampling goes with its message (an unlogged run still samples it, more
cheaply, at 10 Hz), and the simulator's own events (grasp, slip) no longer
become run events; the control, hence the run, is the same (checked: a warning
if the outcomes or simulated durations differ). Parts interact (the caches one empties
slow the others down), so their costs need not add up to ``full`` minus
``no_log``; the remainder is printed.

    .venv/bin/python benchmarks/log_cost.py [--rounds 3] [--scenario pool_fixed] [--seed 1] [--only full,no_log]

The last line is machine-readable:
``log_cost full_us=<x> <part>_us=<cost> ... no_log_us=<y> log_us=<the whole log's cost>`` (medians).
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
MISSION = ROOT / "missions" / "maris_pipe_recovery.yaml"

#: A rate (Hz) so low that its job's period outlasts any run: it runs at step 0 or
#: (a job with a phase offset, the 3D view's) never; the 3D view's first sample
#: at the run's start is written anyway.
ONCE_HZ = 1e-9

#: part -> (SupervisorOptions field, or None for the input record)
PARTS: dict[str, str | None] = {
    "input_record": None,
    "device_log": "device_log_hz",
    "3d_view": "tf_log_hz",
    "ground_truth": "ground_truth_log_hz",
    "kcl": "kcl_log_hz",
}

CONFIGS: dict[str, tuple[str, ...]] = {
    "full": (),
    **{f"-{part}": (part,) for part in PARTS},
    "log_skeleton": tuple(PARTS),
    "no_log": ("no_log",),
}


def run_one(config: str, scenario: str, seed: int) -> dict:
    """Run the mission once in this process with ``config``; its figures."""
    import mission.replay.record  # noqa: F401 - registers the input record of the run's log
    from mission.runtime.api import run_mission
    from mission.runtime.options import RunOptions, RunTarget
    from mission.runtime.result import SupervisorOptions

    left_out = CONFIGS[config]
    rates = {PARTS[p]: ONCE_HZ for p in left_out if PARTS.get(p)}
    with tempfile.TemporaryDirectory() as tmp:
        log_path = None if "no_log" in left_out else Path(tmp) / "bench.mcap"
        result = run_mission(
            RunTarget(MISSION, scenario=scenario, seed=seed),
            RunOptions(
                log_path=log_path, supervisor=SupervisorOptions(**rates), record_inputs="input_record" not in left_out
            ),
        )
        size = log_path.stat().st_size if log_path is not None else 0
    m = result.metrics
    return {
        "config": config,
        "us_per_step": 1e6 * m["wall_s"] / m["steps"],
        "steps": m["steps"],
        "sim_s": result.duration_s,
        "outcome": result.outcome,
        "log_mb": size / 1e6,
    }


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--scenario", default="pool_fixed")
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--only", default=None, help="comma-separated configurations (default: all)")
    ap.add_argument("--one", default=None, help=argparse.SUPPRESS)  # a child process: one run, JSON out
    args = ap.parse_args()
    if args.one is not None:
        print(json.dumps(run_one(args.one, args.scenario, args.seed)))
        return 0
    configs = list(CONFIGS) if args.only is None else [c.strip() for c in args.only.split(",") if c.strip()]
    unknown = [c for c in configs if c not in CONFIGS]
    if unknown:
        ap.error(f"unknown configuration(s) {', '.join(unknown)}; known: {', '.join(CONFIGS)}")
    if args.rounds < 1:
        ap.error("--rounds must be at least 1")
    print(
        f"mission {MISSION.name} scenario={args.scenario} seed={args.seed}, {args.rounds} rounds of "
        f"{len(configs)} configurations, each run in its own process; load average {os.getloadavg()[0]:.1f}",
        flush=True,
    )
    runs: dict[str, list[dict]] = {c: [] for c in configs}
    for r in range(args.rounds):
        for config in configs if r % 2 == 0 else configs[::-1]:  # a drift of the host falls on both ends alike
            out = subprocess.run(
                [sys.executable, __file__, f"--one={config}", "--scenario", args.scenario, "--seed", str(args.seed)],
                capture_output=True,
                text=True,
                cwd=ROOT,
            )
            if out.returncode != 0:
                print(out.stderr[-2000:], file=sys.stderr)
                print(f"error: the {config} run failed (exit {out.returncode})", file=sys.stderr)
                return 1
            rec = json.loads(out.stdout.strip().splitlines()[-1])
            runs[config].append(rec)
            print(
                f"  round {r + 1}/{args.rounds} {config:<14} {rec['us_per_step']:6.0f} us/step "
                f"({rec['outcome']}, {rec['sim_s']:.1f} s simulated)",
                flush=True,
            )
    median = {c: statistics.median(x["us_per_step"] for x in v) for c, v in runs.items()}
    outcomes = {c: {x["outcome"] for x in v} for c, v in runs.items()}
    durations = {round(x["sim_s"], 6) for v in runs.values() for x in v}
    if len({o for s in outcomes.values() for o in s}) > 1 or len(durations) > 1:
        print(f"warning: the runs differ between configurations (outcomes {outcomes}, simulated s {sorted(durations)})")
    sim_s = runs[configs[0]][0]["sim_s"]
    steps = runs[configs[0]][0]["steps"]
    step_us = 1e6 * sim_s / steps  # the base step: a wall time per step of step_us is real time

    def factor(us_per_step: float) -> float:
        """Simulated s per wall s at ``us_per_step`` of loop wall time per base step."""
        return step_us / us_per_step

    print(f"\nsupervisor loop wall time per base step ({steps} steps, {sim_s:.1f} s simulated); median [min-max]")
    for c in configs:
        v = [x["us_per_step"] for x in runs[c]]
        mb = statistics.median(x["log_mb"] for x in runs[c])
        print(
            f"  {c:<14} {median[c]:6.0f} us  [{min(v):.0f}-{max(v):.0f}]  {factor(median[c]):5.1f}x real time"
            f"  log {mb:5.2f} MB"
        )
    fields = []
    if "full" in median:
        full = median["full"]
        fields.append(f"full_us={full:.0f}")
        print(
            "\nwhat each part costs: full minus full without it, in the same round (median [min-max] over the"
            " rounds), and full's real-time factor were it free"
        )

        def paired(config: str) -> list[float]:
            return [f["us_per_step"] - x["us_per_step"] for f, x in zip(runs["full"], runs[config])]

        total_parts = 0.0
        for part in PARTS:
            key = f"-{part}"
            if key in median:
                d = paired(key)
                cost = statistics.median(d)
                total_parts += cost
                fields.append(f"{part}_us={cost:.0f}")
                print(
                    f"  {part:<14} {cost:6.0f} us/step [{min(d):.0f} to {max(d):.0f}]  ({100 * cost / full:4.1f} % of"
                    f" the step)  if free: {factor(full - cost):5.1f}x"
                )
        if "no_log" in median:
            d = paired("no_log")
            log_us = statistics.median(d)
            fields.append(f"no_log_us={median['no_log']:.0f} log_us={log_us:.0f}")
            print(
                f"  the whole log  {log_us:6.0f} us/step [{min(d):.0f} to {max(d):.0f}]  ({100 * log_us / full:4.1f} %)"
                f"  if free: {factor(full - log_us):5.1f}x"
            )
            if all(f"-{p}" in median for p in PARTS):
                print(
                    f"  not in the parts above (the rest of the log, interactions): {log_us - total_parts:.0f} us/step"
                )
    print("log_cost " + " ".join(fields or [f"{c}_us={median[c]:.0f}" for c in configs]))
    return 0


if __name__ == "__main__":
    sys.exit(main())
