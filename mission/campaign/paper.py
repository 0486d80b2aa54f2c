"""The MARIS field result (Simetti et al. 2018, Table I) reproduced on the simulator.

Three configurations of the reference mission on the pool scenarios, each run
with the same per-run seeds (common random numbers: run i sees the same pipe
pose, start pose and noise draws in every configuration, so differences come
from the configuration, not from luck):

* (a) ``no_dvl``: scenario ``pool_no_dvl`` (no measured vehicle velocity), arm
  compensation off - the 2015 campaigns;
* (b) ``unfiltered``: ``pool_clear``, compensation on, feedback filter disabled;
* (c) ``filtered_50``: ``pool_clear``, compensation on, 50 rad/s first-order
  feedback filter - the April 2016 campaign.

:func:`regenerate` runs them and writes ``docs/results.md`` plus two PNG charts
next to it (``results/``). Nothing here tunes the simulator: the scenarios are
used as shipped, and the text states whatever comes out.
"""

from __future__ import annotations

import math
import os
import platform
import sys
import time
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any, Sequence

from mission.campaign.plan import RunSpec, plan_campaign
from mission.campaign.records import FAILURE_OUTCOMES, RunRecord
from mission.campaign.stats import Summary, summarize, wilson_interval

REPO = Path(__file__).resolve().parents[2]
REFERENCE_MISSION = REPO / "missions" / "maris_pipe_recovery.yaml"
OSC_METRIC = "grasp_osc_rms_rad_s"
#: the same measure above 10 Hz: only fast jitter (sensor noise band), not the approach transients
OSC_METRIC_10HZ = "grasp_osc_rms_10hz_rad_s"


@dataclass(frozen=True)
class Config:
    """One configuration of the experiment."""

    key: str
    label: str
    scenario: str
    controller: dict[str, Any]
    paper: str  # what the paper reports for the matching field setup


CONFIGS: tuple[Config, ...] = (
    Config("no_dvl", "(a) no DVL", "pool_no_dvl", {"compensation": False},
           "Oct 2015: 4/16 = 25 %; Dec 2015: 4/13 = 30.7 %"),
    Config("unfiltered", "(b) DVL, unfiltered", "pool_clear", {"compensation": True, "filter_cutoff_rad_s": None},
           "not reported as a campaign; arm oscillated, excited the vehicle"),
    Config("filtered_50", "(c) DVL, 50 rad/s filter", "pool_clear",
           {"compensation": True, "filter_cutoff_rad_s": 50.0}, "Apr 2016: 12/17 = 70.5 %"),
)

#: paper's success counts per configuration key (successes, attempts); (a) pools the two 2015 campaigns
PAPER_COUNTS: dict[str, tuple[int, int]] = {"no_dvl": (8, 29), "filtered_50": (12, 17)}


def plan_paper(runs: int, seed: int, mission: str | Path = REFERENCE_MISSION) -> list[tuple[Config, list[RunSpec]]]:
    """The runs of every configuration; indices are unique across configurations
    (config k, run i -> k * runs + i) and seeds are shared."""
    out = []
    for k, cfg in enumerate(CONFIGS):
        plan = plan_campaign(mission, cfg.scenario, runs, seed, controller=cfg.controller, measure=("oscillation",))
        out.append((cfg, [replace(s, index=k * runs + s.index) for s in plan.runs]))
    return out


def _quantiles(values: Sequence[float]) -> tuple[int, float, float, float]:
    import numpy as np

    v = np.array([x for x in values if x is not None and math.isfinite(x)], dtype=float)
    if v.size == 0:
        return 0, math.nan, math.nan, math.nan
    return int(v.size), float(np.median(v)), float(np.percentile(v, 25)), float(np.percentile(v, 75))


def _f(x: float, digits: int = 4) -> str:
    return "n/a" if x is None or not math.isfinite(x) else f"{x:.{digits}f}"


def _ci(s: Summary) -> str:
    lo, hi = s.ci95
    return f"{100 * lo:.1f}-{100 * hi:.1f} %"


def _paper_cell(key: str) -> str:
    if key not in PAPER_COUNTS:
        return "-"
    k, n = PAPER_COUNTS[key]
    lo, hi = wilson_interval(k, n)
    return f"{k}/{n} = {100 * k / n:.1f} % ({100 * lo:.1f}-{100 * hi:.1f} %)"


def oscillation_verdict(b: Sequence[float], c: Sequence[float]) -> str:
    """One honest sentence comparing the oscillation of (b) with (c)."""
    nb, mb, _, _ = _quantiles(b)
    nc, mc, _, _ = _quantiles(c)
    if nb == 0 or nc == 0:
        return "no grasp phase was reached in one of (b)/(c), so their oscillation cannot be compared."
    ratio = mb / mc if mc > 0 else math.inf
    if ratio >= 1.5:
        return (f"unfiltered feedback (b) oscillates more than filtered (c): median high-passed joint reference "
                f"velocity {mb:.5f} vs {mc:.5f} rad/s ({ratio:.1f} times), as the paper found.")
    if ratio > 1 / 1.5:
        return (f"no clear difference between (b) and (c) in this band: medians {mb:.5f} vs {mc:.5f} rad/s "
                f"(ratio {ratio:.2f}, under the 1.5 this page calls an oscillation).")
    return (f"contrary to the paper, (b) oscillates less than (c) here (median {mb:.5f} vs {mc:.5f} rad/s).")


def paired_text(a: Sequence[RunRecord], c: Sequence[RunRecord]) -> str:
    """Paired comparison of two configurations run with the same seeds (exact McNemar)."""
    from mission.campaign.stats import mcnemar_exact

    by_seed = {r.seed: r.success for r in c}
    only_a = sum(1 for r in a if r.seed in by_seed and r.success and not by_seed[r.seed])
    only_c = sum(1 for r in a if r.seed in by_seed and not r.success and by_seed[r.seed])
    p = mcnemar_exact(only_a, only_c)
    return (f"Paired by seed: {only_c} runs succeed only with (c), {only_a} only with (a); exact McNemar "
            f"p = {p:.3g} ({'significant' if p < 0.05 else 'not significant'} at 5 %).")


def success_verdict(a: Summary, c: Summary) -> str:
    """One honest sentence comparing (a) with (c) by their Wilson intervals."""
    (alo, ahi), (clo, chi) = a.ci95, c.ci95
    if clo > ahi:
        return (f"Compensation with the filtered DVL velocity (c) grasps more often than without DVL (a): "
                f"{100 * c.rate:.1f} % vs {100 * a.rate:.1f} %, and the 95 % intervals do not overlap.")
    if alo > chi:
        return (f"Contrary to the paper, (a) without DVL grasps more often than (c): {100 * a.rate:.1f} % vs "
                f"{100 * c.rate:.1f} %, intervals do not overlap.")
    return (f"The 95 % intervals of (a) {100 * a.rate:.1f} % and (c) {100 * c.rate:.1f} % overlap at this number "
            f"of runs.")


def paper_verdict(cfg: Config, s: Summary) -> str | None:
    """One sentence comparing a configuration with the paper's field rate, by Wilson intervals."""
    if cfg.key not in PAPER_COUNTS or not s.runs:
        return None
    k, n = PAPER_COUNTS[cfg.key]
    plo, phi = wilson_interval(k, n)
    lo, hi = s.ci95
    ours, theirs = f"{100 * s.rate:.1f} %", f"{100 * k / n:.1f} %"
    if lo > phi:
        return f"{cfg.label}: {ours} on the simulator is higher than the field's {theirs} (intervals do not overlap)."
    if hi < plo:
        return f"{cfg.label}: {ours} on the simulator is lower than the field's {theirs} (intervals do not overlap)."
    return f"{cfg.label}: {ours} on the simulator is consistent with the field's {theirs} (intervals overlap)."


def render_markdown(groups: list[tuple[Config, list[RunRecord]]], *, runs: int, seed: int, command: str,
                    wall_s: float, workers: str, charts: tuple[str, str]) -> str:
    """The text of docs/results.md."""
    sums = {cfg.key: summarize(recs) for cfg, recs in groups}
    osc = {cfg.key: [r.metrics.get(OSC_METRIC, math.nan) for r in recs] for cfg, recs in groups}
    osc10 = {cfg.key: [r.metrics.get(OSC_METRIC_10HZ, math.nan) for r in recs] for cfg, recs in groups}
    total = sum(len(recs) for _, recs in groups)
    L: list[str] = []
    L += ["# Results: the MARIS field result on the simulator", "",
          "<!-- generated file: edit mission/campaign/paper.py, then regenerate -->", "",
          f"Regenerate with `{command}` (about {wall_s / 60:.0f} min here).", "",
          f"- mission: `{REFERENCE_MISSION.relative_to(REPO)}`; {runs} runs per configuration, campaign seed {seed}; "
          f"run i uses the same seed (numpy `SeedSequence({seed}).spawn`) in every configuration;",
          f"- machine: {platform.machine()} {platform.system()}, {os.cpu_count()} CPUs, Python "
          f"{platform.python_version()}, {workers}; {total} runs in {wall_s:.0f} s "
          f"({60 * total / wall_s if wall_s > 0 else math.nan:.1f} runs/min);",
          "- success = mission succeeded with the simulator's truth saying the pipe is held; 95 % intervals are "
          "Wilson score intervals (also for the paper's counts).", ""]
    L += ["## Grasp success", "",
          "| configuration | scenario | controller | runs | success | 95 % CI | paper (field, 95 % CI) |",
          "|---|---|---|---|---|---|---|"]
    for cfg, _ in groups:
        s = sums[cfg.key]
        ctl = ", ".join(f"{k}={'off' if v is None else v}" for k, v in cfg.controller.items())
        L.append(f"| {cfg.label} | `{cfg.scenario}` | {ctl} | {s.runs} | {s.successes} ({100 * s.rate:.1f} %) | "
                 f"{_ci(s)} | {_paper_cell(cfg.key)} |")
    L += ["", "Paper, Table I: " + "; ".join(f"{c.label}: {c.paper}" for c in CONFIGS) + ".", ""]
    L += ["Failure causes (runs):", "", "| configuration | " + " | ".join(FAILURE_OUTCOMES) + " |",
          "|---|" + "---|" * len(FAILURE_OUTCOMES)]
    for cfg, _ in groups:
        L.append(f"| {cfg.label} | " + " | ".join(str(sums[cfg.key].counts.get(o, 0)) for o in FAILURE_OUTCOMES) + " |")
    L += ["", f"![success rates]({charts[0]})", ""]
    L += ["## Oscillation of the joint reference velocities", "",
          "Measure: RMS over joints and time of the joint reference velocities produced by the KCL at every arm "
          "step (100 Hz), after a zero-phase 2nd-order 1 Hz Butterworth high-pass, only while the KCL runs the "
          "`grasp` action (`mission.campaign.oscillation`, recorded by `mission.campaign.single`). Slow approach "
          "motion scores ~0; jitter that follows sensor noise scores its amplitude. rad/s. The same with a "
          "10 Hz high-pass keeps only fast jitter (the band of unfiltered sensor noise) and drops most of the "
          "approach transients. (b) is said to oscillate more than (c) when its median is at least 1.5 times "
          "larger.", "",
          "| configuration | runs with a grasp phase | median > 1 Hz | quartiles > 1 Hz | median > 10 Hz | "
          "quartiles > 10 Hz |", "|---|---|---|---|---|---|"]
    for cfg, _ in groups:
        n, med, q1, q3 = _quantiles(osc[cfg.key])
        _, med10, p1, p3 = _quantiles(osc10[cfg.key])
        L.append(f"| {cfg.label} | {n} | {_f(med)} | {_f(q1)}-{_f(q3)} | {_f(med10, 5)} | {_f(p1, 5)}-{_f(p3, 5)} |")
    L += ["", f"![oscillation]({charts[1]})", "", "## What came out", ""]
    recs = {cfg.key: r for cfg, r in groups}
    L.append("- " + success_verdict(sums["no_dvl"], sums["filtered_50"]) + " "
             + paired_text(recs["no_dvl"], recs["filtered_50"]))
    for cfg, _ in groups:
        sentence = paper_verdict(cfg, sums[cfg.key])
        if sentence:
            L.append("- " + sentence)
    L.append("- Above 1 Hz: " + oscillation_verdict(osc["unfiltered"], osc["filtered_50"]))
    L.append("- Above 10 Hz: " + oscillation_verdict(osc10["unfiltered"], osc10["filtered_50"]))
    L += ["- The simulator's parameters are those of the shipped scenarios (`sim_backend/scenarios/`), not fitted "
          "to the paper; the field numbers come from 29 and 17 attempts, so their own intervals are wide.", ""]
    errors = [r for _, recs in groups for r in recs if r.outcome == "error"]
    if errors:
        L += [f"- {len(errors)} runs raised (software errors, counted as failures), e.g. run {errors[0].index}: "
              f"`{(errors[0].error or '')[:200]}`", ""]
    return "\n".join(L) + "\n"


def plot_oscillation(groups: list[tuple[Config, list[RunRecord]]], path: Path) -> Path:
    """Box plots of the per-run oscillation measures (> 1 Hz, > 10 Hz) by configuration."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import numpy as np

    labels = [cfg.label for cfg, _ in groups]
    fig, axes = plt.subplots(1, 2, figsize=(12, 4))
    for ax, metric, band in ((axes[0], OSC_METRIC, "> 1 Hz"), (axes[1], OSC_METRIC_10HZ, "> 10 Hz")):
        data = []
        for _cfg, recs in groups:
            v = np.array([r.metrics.get(metric, np.nan) for r in recs], dtype=float)
            data.append(v[np.isfinite(v)])
        ax.boxplot([d if d.size else np.array([np.nan]) for d in data], showfliers=True)
        ax.set_xticks(range(1, len(labels) + 1), labels, fontsize=8)
        ax.set_ylabel(f"joint ref. velocity RMS {band}, rad/s")
        ax.set_title(f"Arm oscillation during grasp, {band} (per run)")
        if all(d.size and np.all(d > 0) for d in data):
            ax.set_yscale("log")
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=100, metadata={"Software": None})
    plt.close(fig)
    return path


def regenerate(out: str | Path = "docs/results.md", runs: int = 50, seed: int = 0, *, workers: int | None = None,
               address: str | None = None, quiet: bool = False, run_fn: Any = None) -> list[tuple[Config, list[RunRecord]]]:
    """Run the three configurations and write ``out`` with its charts in ``<out dir>/results/``."""
    from mission.campaign.executor import default_workers, execute
    from mission.campaign.progress import Progress
    from mission.campaign.report import plot_summaries, write_csv

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
    success_png = plot_summaries([(cfg.label, summarize(recs)) for cfg, recs in groups], chart_dir / "success.png",
                                 reference={c.label: wilson_interval(*PAPER_COUNTS[c.key]) for c in CONFIGS
                                            if c.key in PAPER_COUNTS},
                                 title="Grasp success on the simulator (bars: 95 % Wilson CI; band: paper's CI)")
    osc_png = plot_oscillation(groups, chart_dir / "oscillation.png")
    for cfg, recs in groups:
        write_csv(recs, chart_dir / f"{cfg.key}.csv")
    cmd = "maris campaign --paper" + (f" --runs {runs}" if runs != 50 else "") + (f" --seed {seed}" if seed else "")
    where = "Dask cluster" if address else f"{workers or default_workers()} local worker processes"
    text = render_markdown(groups, runs=runs, seed=seed, command=cmd, wall_s=wall, workers=where,
                           charts=(os.path.relpath(success_png, out.parent), os.path.relpath(osc_png, out.parent)))
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(text)
    if not quiet:
        print(f"wrote {out} ({len(records)} runs in {wall:.0f} s)", file=sys.stderr)
    return groups
