"""Campaign statistics: success rate with a Wilson 95 % interval, outcome counts.

The Wilson score interval behaves at 0 % and 100 % and for small N, where the
normal-approximation interval collapses or leaves [0, 1].
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from dataclasses import dataclass, field
from typing import NamedTuple

from mission.campaign.attempts import ATTEMPT_OUTCOMES
from mission.campaign.records import OUTCOMES, RunRecord

#: two-sided 95 % standard normal quantile
Z95 = 1.959963984540054


class Interval(NamedTuple):
    """A confidence interval of a proportion (0..1)."""

    low: float
    high: float


def wilson_interval(successes: int, n: int, z: float = Z95) -> Interval:
    """Wilson score interval of a binomial proportion; ``(0, 1)`` when ``n == 0``."""
    if n < 0 or successes < 0 or successes > n:
        raise ValueError(f"need 0 <= successes <= n, got {successes}/{n}")
    if n == 0:
        return Interval(0.0, 1.0)
    p = successes / n
    z2 = z * z
    denom = 1.0 + z2 / n
    centre = (p + z2 / (2 * n)) / denom
    half = (z / denom) * math.sqrt(p * (1 - p) / n + z2 / (4 * n * n))
    lo = 0.0 if successes == 0 else max(0.0, centre - half)
    hi = 1.0 if successes == n else min(1.0, centre + half)
    return Interval(lo, hi)


@dataclass(frozen=True)
class Summary:
    """Counts of one campaign; ``rate`` and ``ci95`` are fractions in [0, 1]."""

    runs: int
    successes: int
    counts: dict[str, int] = field(default_factory=dict)

    @property
    def rate(self) -> float:
        return self.successes / self.runs if self.runs else float("nan")

    @property
    def ci95(self) -> Interval:
        return wilson_interval(self.successes, self.runs)


def summarize(records: Iterable[RunRecord]) -> Summary:
    """Count outcomes (every name of :data:`OUTCOMES` present, zeros included)."""
    counts = {name: 0 for name in OUTCOMES}
    n = 0
    for r in records:
        n += 1
        counts[r.outcome] = counts.get(r.outcome, 0) + 1
    return Summary(runs=n, successes=counts["success"], counts=counts)


@dataclass(frozen=True)
class AttemptSummary:
    """Grasp attempts over a campaign (the paper's Table I unit): ``attempts``,
    ``successes``, ``counts`` per attempt outcome, ``times_to_grasp`` (s, per success)."""

    attempts: int
    successes: int
    counts: dict[str, int] = field(default_factory=dict)
    times_to_grasp: tuple[float, ...] = ()

    @property
    def rate(self) -> float:
        return self.successes / self.attempts if self.attempts else float("nan")

    @property
    def ci95(self) -> Interval:
        return wilson_interval(self.successes, self.attempts)

    @property
    def dominant_failure(self) -> str | None:
        """The most frequent failure outcome (None without failures)."""
        fails = {k: v for k, v in self.counts.items() if k != "success" and v > 0}
        return max(fails, key=lambda k: (fails[k], -ATTEMPT_OUTCOMES.index(k))) if fails else None


def summarize_attempts(records: Iterable[RunRecord]) -> AttemptSummary:
    """Count the grasp attempts of all runs by outcome."""
    counts = {name: 0 for name in ATTEMPT_OUTCOMES}
    times: list[float] = []
    for r in records:
        for a in r.attempts:
            counts[a["outcome"]] = counts.get(a["outcome"], 0) + 1
            if a["outcome"] == "success" and a.get("time_to_grasp_s") is not None:
                times.append(float(a["time_to_grasp_s"]))
    n = sum(counts.values())
    return AttemptSummary(attempts=n, successes=counts["success"], counts=counts, times_to_grasp=tuple(times))


def mcnemar_exact(only_first: int, only_second: int) -> float:
    """Two-sided exact McNemar p-value for paired successes.

    With the same seeds in two configurations, ``only_first`` runs succeeded only
    in the first and ``only_second`` only in the second; under "no difference"
    each discordant pair goes either way with probability 1/2.
    """
    if only_first < 0 or only_second < 0:
        raise ValueError("counts must be >= 0")
    n = only_first + only_second
    if n == 0:
        return 1.0
    k = min(only_first, only_second)
    tail = sum(math.comb(n, i) for i in range(k + 1)) / 2.0**n
    return min(1.0, 2.0 * tail)
