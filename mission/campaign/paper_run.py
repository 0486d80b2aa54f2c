"""The MARIS field result reproduced (:mod:`mission.campaign.paper`): the
configurations run, their records kept next to the charts, the results page
written (:mod:`mission.campaign.paper_render`), or written again from the kept
records without running anything."""

from __future__ import annotations

import json
import math
import os
import sys
import time
from pathlib import Path
from typing import Any

from mission.campaign.executor import default_workers, execute
from mission.campaign.paper import CONFIGS, Config, plan_paper
from mission.campaign.paper_render import plot_attempts, plot_oscillation, render_markdown
from mission.campaign.progress import Progress
from mission.campaign.records import RunRecord
from mission.campaign.report import write_csv


def regenerate(
    out: str | Path = "docs/results.md",
    runs: int = 50,
    seed: int = 0,
    *,
    workers: int | None = None,
    address: str | None = None,
    quiet: bool = False,
    run_fn: Any = None,
) -> list[tuple[Config, list[RunRecord]]]:
    """Run the configurations and write ``out`` with its charts in ``<out dir>/results/``."""
    out = Path(out)
    planned = plan_paper(runs, seed)
    specs = [s for _, ss in planned for s in ss]
    progress = None if quiet else Progress(len(specs))
    start = time.monotonic()
    records = execute(specs, run_fn, workers=workers, address=address, on_record=progress)
    wall = time.monotonic() - start
    by_index = {r.index: r for r in records}
    groups = [(cfg, [by_index[s.index] for s in ss]) for cfg, ss in planned]
    chart_dir = out.parent / "results"
    for cfg, recs in groups:
        write_csv(recs, chart_dir / f"{cfg.key}.csv")
    cmd = "maris campaign --paper" + (f" --runs {runs}" if runs != 50 else "") + (f" --seed {seed}" if seed else "")
    where = "Dask cluster" if address else f"{workers or default_workers()} local worker processes"
    load = os.getloadavg()[0] if hasattr(os, "getloadavg") else math.nan
    meta = {"runs": runs, "seed": seed, "command": cmd, "wall_s": wall, "workers": where, "load": load}
    save_records(groups, meta, chart_dir / RECORDS_FILE)
    render_page(groups, meta, out)
    if not quiet:
        print(f"wrote {out} ({len(records)} runs in {wall:.0f} s)", file=sys.stderr)
    return groups


#: every record of the last regeneration, to re-render the page without re-running it
RECORDS_FILE = "records.json"


def save_records(groups: list[tuple[Config, list[RunRecord]]], meta: dict, path: Path) -> None:
    """Write the records (and how they were made) as JSON next to the charts."""
    data = {"meta": meta, "groups": {cfg.key: [r.to_dict() for r in recs] for cfg, recs in groups}}
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps(data, allow_nan=True, sort_keys=True))


def render_page(groups: list[tuple[Config, list[RunRecord]]], meta: dict, out: Path) -> None:
    """Charts and markdown of ``out`` from the records."""
    chart_dir = out.parent / "results"
    success_png = plot_attempts(groups, chart_dir / "success.png")
    osc_png = plot_oscillation(groups, chart_dir / "oscillation.png")
    text = render_markdown(
        groups,
        runs=meta["runs"],
        seed=meta["seed"],
        command=meta["command"],
        wall_s=meta["wall_s"],
        workers=meta["workers"],
        load=meta.get("load", math.nan),
        charts=(os.path.relpath(success_png, out.parent), os.path.relpath(osc_png, out.parent)),
    )
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(text + kept_sections(out))


#: Marks the start of the hand-written sections at the end of the page (e.g. the
#: vision-in-the-loop runs of ``benchmarks/campaign_vision.py``): a regeneration keeps
#: everything from this line on.
KEPT_MARK = "<!-- kept by maris campaign --paper: hand-written sections below -->"


def kept_sections(out: Path) -> str:
    """The hand-written tail of the page ``out`` (from :data:`KEPT_MARK`), or ""."""
    if not out.exists():
        return ""
    old = out.read_text()
    at = old.find(KEPT_MARK)
    return "" if at < 0 else "\n" + old[at:]


def rerender(out: str | Path = "docs/results.md") -> list[tuple[Config, list[RunRecord]]]:
    """Re-render ``out`` and its charts from the records of the last regeneration
    (``<out dir>/results/records.json``), e.g. after a change of the page's text."""
    out = Path(out)
    data = json.loads((out.parent / "results" / RECORDS_FILE).read_text())
    groups = [(cfg, [RunRecord(**r) for r in data["groups"][cfg.key]]) for cfg in CONFIGS if cfg.key in data["groups"]]
    render_page(groups, data["meta"], out)
    return groups
