"""Campaign throughput: runs per minute of the reference mission on this machine.

Runs a Monte Carlo campaign (default 20 runs of missions/maris_pipe_recovery.yaml
on pool_clear, one local worker process per CPU, or a Dask cluster with
``--address``) through the same executor as ``maris campaign``, and prints its
configuration (mission, scenario, runs, workers, CPUs, load average), the
outcomes and the figures. The last line is machine-readable:
``campaign runs_per_min=<x> runs=<n> workers=<w> cpus=<c>``.
Options: --runs N, --workers W, --address tcp://host:8786, --scenario S, --seed K,
--mission FILE (another mission, e.g. another tree's copy of the reference mission to
compare two versions of the code on one mission).
Target (issue 18): >= 200 runs/min with at least 20 runs on a 2-core machine; the
wall time counts from the executor's start, the campaign's own loading included.
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
    ap.add_argument("--runs", type=int, default=20)
    ap.add_argument("--workers", type=int, default=None)
    ap.add_argument("--address", default=None, help="Dask scheduler address instead of local processes")
    ap.add_argument("--mission", type=Path, default=REPO / "missions" / "maris_pipe_recovery.yaml")
    ap.add_argument("--scenario", default="pool_clear")
    ap.add_argument("--seed", type=int, default=1)
    args = ap.parse_args()
    workers = args.workers or default_workers()
    mission = args.mission
    plan = plan_campaign(mission, args.scenario, args.runs, args.seed)
    where = f"Dask cluster {args.address}" if args.address else f"{workers} local worker processes"
    load0 = os.getloadavg()[0]
    start = time.perf_counter()
    records = execute(plan, workers=workers, address=args.address)
    wall = time.perf_counter() - start
    s = summarize(records)
    sim = [r.duration_s for r in records if r.outcome != "error"]
    per_run = [r.wall_s for r in records]
    print(
        f"mission {mission.name}, scenario {args.scenario}, seed {args.seed}, {args.runs} runs, {where}, "
        f"{os.cpu_count()} CPUs, load average {load0:.1f} before / {os.getloadavg()[0]:.1f} after"
    )
    print(f"outcomes: {', '.join(f'{k}={v}' for k, v in s.counts.items() if v)}")
    if sim:
        print(f"simulated time per run: mean {statistics.mean(sim):.1f} s")
    print(f"wall time per run: mean {statistics.mean(per_run):.1f} s (in its worker)")
    print(f"campaign wall time {wall:.1f} s")
    errors = [r for r in records if r.outcome == "error"]
    for r in errors[:3]:
        print(f"run {r.index} raised: {r.error}", file=sys.stderr)
    n_workers = 0 if args.address else workers
    rate = 60.0 * len(records) / wall
    verdict = "met" if rate >= 200.0 else "MISSED"
    note = "" if len(records) >= 20 else f"; only {len(records)} runs (the target counts at least 20)"
    if not args.address:  # (the target is for this machine's own CPUs)
        print(
            f"target: >= 200 runs/min of the reference mission, >= 20 runs on this machine: {verdict} ({rate:.0f}){note}"
        )
    print(f"campaign runs_per_min={rate:.2f} runs={len(records)} workers={n_workers} cpus={os.cpu_count()}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
