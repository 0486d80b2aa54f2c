"""Campaign throughput: runs per minute of the reference mission on this machine.

Runs a small Monte Carlo campaign (default 4 runs of
missions/maris_pipe_recovery.yaml on pool_clear, one worker per CPU) through
the same executor as ``maris campaign`` and prints the figures; the last line is
``campaign runs_per_min=<x>``. Options: --runs N, --workers W, --scenario S, --seed K.
"""

from __future__ import annotations

import argparse
import os
import statistics
import sys
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

from mission.campaign.executor import default_workers, execute  # noqa: E402
from mission.campaign.plan import plan_campaign  # noqa: E402
from mission.campaign.stats import summarize  # noqa: E402


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=int, default=4)
    ap.add_argument("--workers", type=int, default=None)
    ap.add_argument("--scenario", default="pool_clear")
    ap.add_argument("--seed", type=int, default=1)
    args = ap.parse_args()
    workers = args.workers or default_workers()
    mission = REPO / "missions" / "maris_pipe_recovery.yaml"
    plan = plan_campaign(mission, args.scenario, args.runs, args.seed)
    start = time.perf_counter()
    records = execute(plan, workers=workers)
    wall = time.perf_counter() - start
    s = summarize(records)
    sim = [r.duration_s for r in records if r.outcome != "error"]
    per_run = [r.wall_s for r in records]
    print(f"mission {mission.name}, scenario {args.scenario}, {args.runs} runs, {workers} workers, {os.cpu_count()} CPUs")
    print(f"outcomes: {', '.join(f'{k}={v}' for k, v in s.counts.items() if v)}")
    if sim:
        print(f"simulated time per run: mean {statistics.mean(sim):.1f} s")
    print(f"wall time per run: mean {statistics.mean(per_run):.1f} s (in its worker)")
    print(f"campaign wall time {wall:.1f} s")
    errors = [r for r in records if r.outcome == "error"]
    for r in errors[:3]:
        print(f"run {r.index} raised: {r.error}", file=sys.stderr)
    print(f"campaign runs_per_min={60.0 * len(records) / wall:.2f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
