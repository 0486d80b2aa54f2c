"""Replay speed against the dry run it replays, and the size of the input record.

Dry-runs ``missions/maris_pipe_recovery.yaml`` on the simulator with logging on
(input record included), then replays that log exactly (``maris log replay``,
same supervisor code against a backend serving the logged readings, writing its
own log) and compares. Both speeds are simulated seconds per wall second of the
supervisor run (``benchmarks/dry_run.py``'s measure: loading the mission and
models excluded; both runs write a log). Also printed: the replay's loading and
comparison times, the log size per minute of mission with and without the input
record (a second dry run without it), CPU figures (less sensitive to other load
on a shared machine). Target: the replay at least as fast as the dry run.

    .venv/bin/python benchmarks/replay.py [--scenario pool_fixed] [--seed 1]

Last line: ``replay realtime_factor=<r> dry_run_realtime_factor=<d> log_mb_per_min=<m> input_record_mb_per_min=<i>``.
"""

from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--mission", default=str(ROOT / "missions" / "maris_pipe_recovery.yaml"))
    ap.add_argument("--scenario", default="pool_fixed")
    ap.add_argument("--seed", type=int, default=1)
    args = ap.parse_args()

    from mission.replay.run import replay_log
    from mission.runtime.api import run_mission

    with tempfile.TemporaryDirectory() as tmp:
        log = Path(tmp) / "run.mcap"
        bare = Path(tmp) / "bare.mcap"
        run_mission(args.mission, scenario=args.scenario, seed=args.seed, log_path=bare, record_inputs=False)
        bare_mb = bare.stat().st_size / 1e6
        cpu0 = time.process_time()
        result = run_mission(args.mission, scenario=args.scenario, seed=args.seed, log_path=log)
        dry_cpu = time.process_time() - cpu0
        log_mb = log.stat().st_size / 1e6
        cpu0 = time.process_time()
        report = replay_log(log)
        replay_cpu = time.process_time() - cpu0
    dur = result.duration_s
    dry_rtf = dur / result.metrics["wall_s"]
    rep_rtf = report.mission_s / report.wall_s
    per_min = 60.0 / dur
    print(f"mission      {Path(args.mission).name} scenario={args.scenario} seed={args.seed}, {dur:.1f} s simulated, "
          f"{result.metrics['steps']} loop steps")
    print(f"dry run      {result.metrics['wall_s']:.2f} s supervisor run -> {dry_rtf:.1f}x real time "
          f"(cpu {dry_cpu:.2f} s incl. loading)")
    print(f"replay       {report.wall_s:.2f} s supervisor run -> {rep_rtf:.1f}x real time; loading {report.setup_wall_s:.2f} s, "
          f"comparison {report.compare_wall_s:.2f} s (cpu {replay_cpu:.2f} s incl. reading, loading, comparing)")
    print(f"             identical={report.identical} ({report.steps} steps compared)")
    print(f"log size     {log_mb:.2f} MB = {log_mb * per_min:.1f} MB per minute of mission; without the input record "
          f"{bare_mb:.2f} MB = {bare_mb * per_min:.1f} MB/min (input record {(log_mb - bare_mb) * per_min:.1f} MB/min)")
    print(f"replay realtime_factor={rep_rtf:.1f} dry_run_realtime_factor={dry_rtf:.1f} "
          f"log_mb_per_min={log_mb * per_min:.2f} input_record_mb_per_min={(log_mb - bare_mb) * per_min:.2f}")


if __name__ == "__main__":
    main()
