"""Wilson interval and outcome counts."""

import math

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from mission.campaign.records import OUTCOMES, RunRecord
from mission.campaign.stats import Z95, summarize, wilson_interval


def _wilson_by_roots(k: int, n: int, z: float = Z95) -> tuple[float, float]:
    """Independent form: the bounds are the roots in p of (k/n - p)^2 = z^2 p (1 - p) / n."""
    ph = k / n
    a = 1 + z * z / n
    b = -(2 * ph + z * z / n)
    c = ph * ph
    disc = math.sqrt(max(b * b - 4 * a * c, 0.0))
    return ((-b - disc) / (2 * a), (-b + disc) / (2 * a))


def test_paper_campaign_values():
    # April 2016: 12 of 17 (70.5 %); Oct 2015: 4 of 16 (25 %)
    lo, hi = wilson_interval(12, 17)
    assert lo == pytest.approx(0.4687, abs=1e-3) and hi == pytest.approx(0.8672, abs=1e-3)
    lo, hi = wilson_interval(4, 16)
    assert lo == pytest.approx(0.1018, abs=1e-3) and hi == pytest.approx(0.4950, abs=1e-3)


def test_edges():
    assert wilson_interval(0, 0) == (0.0, 1.0)
    lo, hi = wilson_interval(0, 10)
    assert lo == 0.0 and 0.2 < hi < 0.35
    lo, hi = wilson_interval(10, 10)
    assert hi == 1.0 and 0.65 < lo < 0.8
    with pytest.raises(ValueError):
        wilson_interval(5, 4)


@settings(max_examples=100, deadline=None)
@given(st.integers(1, 5000).flatmap(lambda n: st.tuples(st.integers(0, n), st.just(n))))
def test_matches_quadratic_roots_and_contains_estimate(kn):
    k, n = kn
    lo, hi = wilson_interval(k, n)
    rlo, rhi = _wilson_by_roots(k, n)
    assert lo == pytest.approx(max(rlo, 0.0), abs=1e-9)
    assert hi == pytest.approx(min(rhi, 1.0), abs=1e-9)
    assert 0.0 <= lo <= k / n <= hi <= 1.0


def test_summarize_counts_every_outcome():
    recs = [RunRecord(i, i, o) for i, o in enumerate(["success", "success", "timeout", "error", "abort"])]
    s = summarize(recs)
    assert s.runs == 5 and s.successes == 2 and s.rate == 0.4
    assert set(s.counts) == set(OUTCOMES)
    assert s.counts["timeout"] == 1 and s.counts["not_detected"] == 0


def test_mcnemar_exact():
    from mission.campaign.stats import mcnemar_exact

    assert mcnemar_exact(0, 0) == 1.0
    assert mcnemar_exact(0, 5) == pytest.approx(2 / 32)
    assert mcnemar_exact(5, 0) == mcnemar_exact(0, 5)
    assert mcnemar_exact(1, 10) == pytest.approx(2 * 12 / 2048)
    assert mcnemar_exact(3, 3) == 1.0
