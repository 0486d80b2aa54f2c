"""The MARIS field result (Simetti et al. 2018, Table I) reproduced on the simulator.

Four configurations, each like one field campaign (maris.md, "What each
campaign was"), run with the same per-run seeds (common random numbers: run i
sees the same pipe pose, start pose and noise draws in every configuration that
shares its scenario ranges, so differences come from the configuration):

* ``oct2015``: October 2015, very turbid water, vehicle held over the pipe by
  divers, thrusters off, arm-only grasp (``missions/maris_arm_only_grasp.yaml``
  on ``pool_oct2015``), no DVL;
* ``dec2015``: December 2015, clear water, coordinated vehicle + arm control
  without DVL (reference mission on ``pool_dec2015``, compensation off);
* ``apr2016_unfiltered``: the April 2016 setup with the vehicle velocity fed
  back unfiltered (the oscillation the paper reports, not a campaign of its own);
* ``apr2016``: April 2016, DVL, compensation with the 50 rad/s filter.

Scores: per grasp attempt (Table I's unit, :mod:`mission.campaign.attempts`)
and per mission, with Wilson intervals, beside the paper's counts.
:func:`mission.campaign.paper_run.regenerate` runs them and writes
``docs/results.md`` (:mod:`mission.campaign.paper_render`) plus charts in
``docs/results/``. Nothing
here tunes the simulator: scenarios are used as shipped, the text states what
comes out.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any, NamedTuple

import numpy as np

from mission.campaign.plan import RunSpec, plan_campaign
from mission.campaign.records import RunRecord
from mission.campaign.stats import AttemptSummary, Interval, Summary, mcnemar_exact, wilson_interval

REPO = Path(__file__).resolve().parents[2]
REFERENCE_MISSION = REPO / "missions" / "maris_pipe_recovery.yaml"
ARM_ONLY_MISSION = REPO / "missions" / "maris_arm_only_grasp.yaml"
#: joint reference velocities above 1 Hz / 10 Hz (rad/s)
OSC_METRIC = "grasp_osc_rms_rad_s"
OSC_METRIC_10HZ = "grasp_osc_rms_10hz_rad_s"
#: actual motion above 1 Hz: vehicle angular rate (rad/s), tool position (m)
VEHICLE_OSC_METRIC = "grasp_vehicle_rate_osc_rad_s"
TOOL_OSC_METRIC = "grasp_tool_osc_m"
#: the same above 8 Hz, the corner of the KCL's 50 rad/s filter
VEHICLE_OSC_METRIC_8HZ = "grasp_vehicle_rate_osc_8hz_rad_s"
TOOL_OSC_METRIC_8HZ = "grasp_tool_osc_8hz_m"
#: ratio at which one configuration is said to oscillate more than another
OSC_RATIO = 2.0


class FieldCounts(NamedTuple):
    """What the paper counts for one field campaign (Table I)."""

    grasps: int  # successful grasps
    attempts: int


@dataclass(frozen=True)
class Config:
    """One configuration of the experiment; ``paper``: the matching field counts
    (successful grasps, attempts) or None; ``field``: what the paper says of it."""

    key: str
    label: str
    mission: Path
    scenario: str
    controller: dict[str, Any]
    paper: FieldCounts | None
    field: str


CONFIGS: tuple[Config, ...] = (
    Config(
        "oct2015",
        "(a) Oct 2015: arm only, held, very turbid",
        ARM_ONLY_MISSION,
        "pool_oct2015",
        {"compensation": False},
        FieldCounts(4, 16),
        "Oct 2015: 4/16 = 25 % (bad visibility)",
    ),
    Config(
        "dec2015",
        "(b) Dec 2015: coordinated, no DVL",
        REFERENCE_MISSION,
        "pool_dec2015",
        {"compensation": False},
        FieldCounts(4, 13),
        "Dec 2015: 4/13 = 30.7 % (no convergence to the grasp pose)",
    ),
    Config(
        "apr2016_unfiltered",
        "(c) Apr 2016 setup, unfiltered feedback",
        REFERENCE_MISSION,
        "pool_apr2016",
        {"compensation": True, "filter_cutoff_rad_s": None},
        None,
        "not a campaign; the arm oscillated and excited the vehicle (Fig. 17)",
    ),
    Config(
        "apr2016",
        "(d) Apr 2016: DVL, 50 rad/s filter",
        REFERENCE_MISSION,
        "pool_apr2016",
        {"compensation": True, "filter_cutoff_rad_s": 50.0},
        FieldCounts(12, 17),
        "Apr 2016: 12/17 = 70.5 %",
    ),
)
CONFIG_BY_KEY = {c.key: c for c in CONFIGS}


def plan_paper(runs: int, seed: int) -> list[tuple[Config, list[RunSpec]]]:
    """The runs of every configuration; indices are unique across configurations
    (config k, run i -> k * runs + i) and seeds are shared."""
    out = []
    for k, cfg in enumerate(CONFIGS):
        plan = plan_campaign(cfg.mission, cfg.scenario, runs, seed, controller=cfg.controller, measure=("oscillation",))
        out.append((cfg, [replace(s, index=k * runs + s.index) for s in plan.runs]))
    return out


# ----------------------------------------------------------------------------- numbers and verdicts


def quantiles(values: Sequence[float]) -> tuple[int, float, float, float]:
    """``(n, median, q1, q3)`` of the finite values."""
    v = np.array([x for x in values if x is not None and math.isfinite(x)], dtype=float)
    if v.size == 0:
        return 0, math.nan, math.nan, math.nan
    return int(v.size), float(np.median(v)), float(np.percentile(v, 25)), float(np.percentile(v, 75))


def paper_interval(cfg: Config) -> Interval | None:
    return None if cfg.paper is None else wilson_interval(*cfg.paper)


def paper_verdict(cfg: Config, s: AttemptSummary | Summary) -> str | None:
    """One sentence comparing a configuration's success rate with the paper's, by
    the paper's interval and by overlap of the two Wilson intervals."""
    if cfg.paper is None or not _n(s):
        return None
    k, n = cfg.paper
    plo, phi = wilson_interval(k, n)
    lo, hi = s.ci95
    ours, theirs = f"{100 * s.rate:.1f} %", f"{100 * k / n:.1f} %"
    inside = plo <= s.rate <= phi
    where = "inside" if inside else ("above" if s.rate > phi else "below")
    overlap = "overlap" if lo <= phi and plo <= hi else "do not overlap"
    return (
        f"{cfg.label}: {ours} on the simulator, {where} the field's interval "
        f"{100 * plo:.1f}-{100 * phi:.1f} % around {theirs} (the two intervals {overlap})."
    )


def _n(s: AttemptSummary | Summary) -> int:
    return s.attempts if isinstance(s, AttemptSummary) else s.runs


def ratio_verdict(without: AttemptSummary, with_: AttemptSummary) -> str:
    """The with/without-DVL ratio of per-attempt success (target: >= 2)."""
    if not without.attempts or not with_.attempts:
        return "no attempts in one of the two configurations: no ratio."
    if without.rate == 0:
        return f"with the DVL {100 * with_.rate:.1f} % of attempts succeed, without it none: the ratio is unbounded."
    r = with_.rate / without.rate
    return (
        f"per-attempt success with the DVL and filter is {r:.2f} times that without DVL "
        f"({100 * with_.rate:.1f} % vs {100 * without.rate:.1f} %; the paper: 70.5 / 30.7 = 2.3; target >= 2: "
        f"{'met' if r >= 2.0 else 'missed'})."
    )


def oscillation_verdict(unfiltered: Sequence[float], filtered: Sequence[float], what: str) -> str:
    """One honest sentence comparing the oscillation of the unfiltered and filtered runs."""
    nb, mb, _, _ = quantiles(unfiltered)
    nc, mc, _, _ = quantiles(filtered)
    if nb == 0 or nc == 0:
        return f"{what}: no grasp phase with a measurement in one of (c)/(d), no comparison."
    ratio = mb / mc if mc > 0 else math.inf
    if ratio >= OSC_RATIO:
        return (
            f"{what}: unfiltered feedback (c) oscillates more than filtered (d), median {mb:.3g} vs {mc:.3g} "
            f"({ratio:.1f} times; the target is {OSC_RATIO:g})."
        )
    if ratio > 1 / OSC_RATIO:
        return (
            f"{what}: no clear difference between (c) and (d): median {mb:.3g} vs {mc:.3g} "
            f"(ratio {ratio:.2f}, under the {OSC_RATIO:g} this page calls an oscillation)."
        )
    return f"{what}: contrary to the paper, (c) oscillates less than (d) (median {mb:.3g} vs {mc:.3g})."


def paired_text(a: Sequence[RunRecord], c: Sequence[RunRecord], names: tuple[str, str]) -> str:
    """Paired comparison of mission success in two configurations run with the same seeds (exact McNemar)."""
    by_seed = {r.seed: r.success for r in c}
    only_a = sum(1 for r in a if r.seed in by_seed and r.success and not by_seed[r.seed])
    only_c = sum(1 for r in a if r.seed in by_seed and not r.success and by_seed[r.seed])
    p = mcnemar_exact(only_a, only_c)
    return (
        f"Paired by seed (missions): {only_c} runs succeed only with {names[1]}, {only_a} only with {names[0]}; "
        f"exact McNemar p = {p:.3g} ({'significant' if p < 0.05 else 'not significant'} at 5 %)."
    )
