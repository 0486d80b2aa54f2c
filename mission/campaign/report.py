"""Campaign output: the text table, the CSV file and the PNG chart.

Everything written here depends only on the records (never on wall time), so a
campaign re-run with the same seed gives byte-identical tables and CSV files.
"""

from __future__ import annotations

import csv
import math
import textwrap
from collections.abc import Sequence
from pathlib import Path

from mission.campaign.attempts import ATTEMPT_OUTCOMES
from mission.campaign.records import OUTCOMES, RunRecord
from mission.campaign.stats import Summary, summarize, summarize_attempts

CSV_FIELDS = ("index", "seed", "outcome", "duration_s", "grasp", "failure_cause", "error", "attempts")


def _num(x: float | None) -> str:
    if x is None:
        return ""
    x = float(x)
    return f"{x:.6g}" if math.isfinite(x) else ("nan" if math.isnan(x) else ("inf" if x > 0 else "-inf"))


def pct(x: float) -> str:
    """A fraction as a percentage with one decimal (``"70.5 %"``)."""
    return "n/a" if math.isnan(x) else f"{100 * x:.1f} %"


def rate_text(s: Summary) -> str:
    """``"35/50 = 70.0 % (95 % CI 56.2-80.9 %)"``."""
    lo, hi = s.ci95
    return f"{s.successes}/{s.runs} = {pct(s.rate)} (95 % CI {100 * lo:.1f}-{100 * hi:.1f} %)"


#: What ``success`` means, by the mission's own criterion (see ``mission_grasps``).
SUCCESS_LABELS = {"grasp": "grasp success", "mission": "mission success"}
#: Outcomes that only a grasping mission can have.
GRASP_OUTCOMES = ("grasp_missed",)


def format_table(records: Sequence[RunRecord], title: str = "", criterion: str = "grasp") -> str:
    """Plain-text summary: success rate with its Wilson interval, outcome counts.
    ``criterion``: ``grasp`` (success = the object is held at the end) or
    ``mission`` (success = the mission succeeded; for missions that do not grasp).
    Then the grasp attempts (the MARIS paper's unit) the same way, when there were any."""
    s = summarize(records)
    a = summarize_attempts(records)
    lines = [title] if title else []
    if criterion == "mission":
        lines.append(f"mission success rate: {rate_text(s)}  [success: the mission succeeded; it grasps nothing]")
    else:
        lines.append(f"grasp success rate: {rate_text(s)}  [success: the mission succeeded with the object held]")
    lines.append(f"{'outcome':<14}{'runs':>6}{'share':>9}")
    for name in OUTCOMES:
        if criterion == "mission" and name in GRASP_OUTCOMES and not s.counts.get(name):
            continue
        n = s.counts.get(name, 0)
        lines.append(f"{name:<14}{n:>6}{pct(n / s.runs if s.runs else float('nan')):>9}")
    if a.attempts:
        lo, hi = a.ci95
        lines.append(
            f"grasp attempt success rate: {a.successes}/{a.attempts} = {pct(a.rate)} "
            f"(95 % CI {100 * lo:.1f}-{100 * hi:.1f} %)"
        )
        lines.append(f"{'attempt outcome':<18}{'tries':>6}{'share':>9}")
        for name in ATTEMPT_OUTCOMES:
            n = a.counts.get(name, 0)
            lines.append(f"{name:<18}{n:>6}{pct(n / a.attempts):>9}")
    errors = [r for r in records if r.outcome == "error"]
    for r in errors[:5]:
        lines.append(f"  run {r.index} (seed {r.seed}) raised: {r.error}")
    if len(errors) > 5:
        lines.append(f"  ... and {len(errors) - 5} more errors (see the CSV)")
    return "\n".join(lines)


def metric_names(records: Sequence[RunRecord]) -> list[str]:
    """Sorted union of the metric names of all records."""
    return sorted({k for r in records for k in r.metrics})


def write_csv(records: Sequence[RunRecord], path: str | Path) -> Path:
    """One row per run, ordered by index; metrics as extra columns (``m_<name>``)."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    metrics = metric_names(records)
    with path.open("w", newline="") as f:
        w = csv.writer(f, lineterminator="\n")
        w.writerow([*CSV_FIELDS, *(f"m_{m}" for m in metrics), "log_path"])
        for r in sorted(records, key=lambda r: r.index):
            w.writerow(
                [
                    r.index,
                    r.seed,
                    r.outcome,
                    _num(r.duration_s),
                    r.grasp or "",
                    r.failure_cause or "",
                    (r.error or "").replace("\n", " "),
                    ";".join(a["outcome"] for a in r.attempts),
                    *(_num(r.metrics.get(m)) for m in metrics),
                    r.log_path or "",
                ]
            )
    return path


_COLOURS = {
    "success": "#2ca02c",
    "not_detected": "#7f7f7f",
    "grasp_missed": "#ff7f0e",
    "timeout": "#9467bd",
    "abort": "#d62728",
    "error": "#000000",
}


def plot_summaries(
    groups: Sequence[tuple[str, Summary]],
    path: str | Path,
    *,
    reference: dict[str, tuple[float, float]] | None = None,
    title: str = "",
    criterion: str = "grasp",
) -> Path:
    """PNG chart: success rate with Wilson 95 % bars (left), outcome shares (right).

    ``reference`` maps a group label to a (low, high) success-rate band drawn
    behind its bar (e.g. the paper's field result), fractions in [0, 1].
    """
    import matplotlib  # plotting only: matplotlib loads when a chart is drawn

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    labels = [label.replace(", ", ",\n") for label, _ in groups]  # wrapped tick labels
    xs = range(len(groups))
    fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(max(7.0, 2.2 * len(groups) + 4), 3.8))
    for x, (label, s) in zip(xs, groups):
        if reference and label in reference:
            lo, hi = reference[label]
            ax1.fill_between(
                [x - 0.4, x + 0.4],
                [100 * lo] * 2,
                [100 * hi] * 2,
                color="#1f77b4",
                alpha=0.15,
                label="paper (field)" if x == 0 else None,
            )
        if s.runs:
            lo, hi = s.ci95
            ax1.bar(x, 100 * s.rate, width=0.5, color="#2ca02c")
            ax1.errorbar(x, 100 * s.rate, yerr=[[100 * (s.rate - lo)], [100 * (hi - s.rate)]], color="k", capsize=5)
    ax1.set_xticks(list(xs), labels)
    ax1.set_ylim(0, 100)
    ax1.set_ylabel(f"{SUCCESS_LABELS.get(criterion, 'success')}, % (95 % Wilson CI)")
    if reference:
        ax1.legend(loc="upper left", fontsize=8)
    bottoms = [0.0] * len(groups)
    for name in OUTCOMES:
        vals = [100 * s.counts.get(name, 0) / s.runs if s.runs else 0.0 for _, s in groups]
        if any(vals):
            ax2.bar(list(xs), vals, bottom=bottoms, width=0.5, color=_COLOURS[name], label=name)
            bottoms = [b + v for b, v in zip(bottoms, vals)]
    ax2.set_xticks(list(xs), labels)
    ax2.set_ylim(0, 100)
    ax2.set_ylabel("share of runs, %")
    ax2.legend(fontsize=8, loc="center left", bbox_to_anchor=(1.0, 0.5))
    if title:  # wrapped to the figure's width; bbox "tight" keeps it and the outside legend in the image
        fig.suptitle(textwrap.fill(title, width=int(fig.get_figwidth() * 11)), fontsize=10)
    fig.tight_layout()
    fig.savefig(path, dpi=100, metadata={"Software": None}, bbox_inches="tight")
    plt.close(fig)
    return path
