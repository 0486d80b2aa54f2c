"""The paper's Dec 2015 and Apr 2016 configurations with vision in the loop.

``maris campaign --paper`` runs its configurations with the table model of
vision (detections drawn from the truth with the scenarios' detection
probability). This script runs two of them, (b) Dec 2015 (no DVL,
compensation off) and (d) Apr 2016 (DVL, 50 rad/s filter), exactly as the
paper's campaign plans them (same missions, scenarios, controller options and
per-run seeds: ``mission.campaign.paper.plan_paper``), with one override:
``vision.model: rendered`` (stereo pairs rendered at 646 x 482, 10 Hz, and the
real detector and tracker of ``vision/``, as in ``pool_vision``). Beside the
per-attempt and per-mission success (Wilson 95 % intervals) it reports what the
detector did in those runs: frames with the pipe in either camera's view,
frames where it found the pipe, tracked detections published, detections the
tracker rejected (recall = found / in view).

    .venv/bin/python benchmarks/campaign_vision.py [--runs 12] [--workers 1] [--out docs/results/vision.json]

Each run renders and detects for its whole length: minutes of CPU per run.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import time
from dataclasses import replace
from pathlib import Path
from typing import Any

from mission.campaign.deadline import check_deadline
from mission.campaign.executor import execute
from mission.campaign.paper import CONFIG_BY_KEY, plan_paper
from mission.campaign.plan import RunSpec
from mission.campaign.records import RunRecord
from mission.campaign.single import deterministic_metrics, record_of, run_options
from mission.campaign.stats import summarize, summarize_attempts, wilson_interval
from mission.runtime.api import run_mission
from mission.runtime.options import RunHooks, RunTarget

CONFIG_KEYS = ("dec2015", "apr2016")


def run_with_vision_stats(spec: RunSpec) -> RunRecord:
    """One run as :func:`mission.campaign.single.run_one` records it (outcome, grasp
    attempts), plus the rendered detector's counters in its metrics (``vision_*``)."""
    grabbed: dict[str, Any] = {}
    result = run_mission(
        RunTarget(spec.mission_path, scenario=spec.scenario, seed=spec.seed, overrides=dict(spec.overrides)),
        run_options(spec.controller),
        RunHooks(on_progress=lambda *_: check_deadline(), on_supervisor=lambda sup: grabbed.update(sup=sup)),
    )
    metrics = deterministic_metrics(getattr(result, "metrics", {}) or {})
    vision = getattr(getattr(grabbed.get("sup"), "backend", None), "vision", None)
    for k, v in (getattr(vision, "stats", None) or {}).items():
        metrics[f"vision_{k}"] = float(v)
    return record_of(spec, result, metrics)


def wilson(k: int, n: int) -> tuple[float, float]:
    return wilson_interval(k, n)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=int, default=12, help="runs per configuration")
    ap.add_argument("--seed", type=int, default=0, help="campaign seed (the paper page uses 0)")
    ap.add_argument("--workers", type=int, default=1)
    ap.add_argument("--out", default=None, help="write the records and the summary (JSON) here")
    args = ap.parse_args()

    planned = {cfg.key: specs for cfg, specs in plan_paper(args.runs, args.seed) if cfg.key in CONFIG_KEYS}
    specs = [
        replace(s, overrides={**s.overrides, "vision.model": "rendered"}, measure=())
        for key in CONFIG_KEYS
        for s in planned[key]
    ]
    start = time.monotonic()
    done = 0

    def progress(rec) -> None:  # noqa: ANN001
        nonlocal done
        done += 1
        print(
            f"  {done}/{len(specs)} run {rec.index}: {rec.outcome} ({rec.wall_s:.0f} s wall)",
            file=sys.stderr,
            flush=True,
        )

    records = execute(specs, run_with_vision_stats, workers=args.workers, on_record=progress)
    wall = time.monotonic() - start
    by_index = {r.index: r for r in records}
    out: dict = {"runs": args.runs, "seed": args.seed, "wall_s": wall, "configs": {}}
    print(f"\nvision in the loop (rendered 646x482 stereo, the real detector and tracker), {args.runs} runs each")
    for key in CONFIG_KEYS:
        cfg = CONFIG_BY_KEY[key]
        recs = [by_index[s.index] for s in planned[key]]
        att, mis = summarize_attempts(recs), summarize(recs)
        sums = {
            k: sum(r.metrics.get(f"vision_{k}", 0.0) for r in recs)
            for k in ("frames_in_view", "frames_found", "published", "rejected")
        }
        recall = sums["frames_found"] / sums["frames_in_view"] if sums["frames_in_view"] else math.nan
        lo, hi = att.ci95
        mlo, mhi = wilson(mis.successes, mis.runs)
        fails = {k: v for k, v in att.counts.items() if k != "success" and v}
        print(
            f"{cfg.label}: attempts {att.successes}/{att.attempts} = {100 * att.rate:.1f} % ({100 * lo:.1f}-{100 * hi:.1f} %), "
            f"missions {mis.successes}/{mis.runs} ({100 * mlo:.1f}-{100 * mhi:.1f} %); failures {fails}; "
            f"outcomes {dict((k, v) for k, v in mis.counts.items() if v)}"
        )
        print(
            f"   detector: pipe in view in {int(sums['frames_in_view'])} frames, found in {int(sums['frames_found'])} "
            f"(recall {100 * recall:.1f} %), {int(sums['published'])} tracked detections published, "
            f"{int(sums['rejected'])} rejected by the tracker"
        )
        out["configs"][key] = {
            "label": cfg.label,
            "attempts": att.attempts,
            "attempt_successes": att.successes,
            "attempt_ci95": [lo, hi],
            "attempt_counts": att.counts,
            "missions": mis.runs,
            "mission_successes": mis.successes,
            "mission_ci95": [mlo, mhi],
            "mission_counts": mis.counts,
            "vision": sums,
            "recall": recall,
            "paper": cfg.paper,
            "records": [r.to_dict() for r in recs],
        }
    print(f"({len(records)} runs in {wall:.0f} s wall, {args.workers} worker(s))")
    if args.out:
        Path(args.out).parent.mkdir(parents=True, exist_ok=True)
        Path(args.out).write_text(json.dumps(out, indent=1, default=float))
    print(
        "campaign_vision "
        + json.dumps({k: v["attempt_successes"] / max(v["attempts"], 1) for k, v in out["configs"].items()})
    )


if __name__ == "__main__":
    main()
