"""The results page of the MARIS experiment: planning and rendering (no runs here)."""

import math

from mission.campaign.paper import (CONFIGS, OSC_METRIC, OSC_METRIC_10HZ, oscillation_verdict, plan_paper, render_markdown,
                                    success_verdict)
from mission.campaign.records import RunRecord
from mission.campaign.stats import summarize


def test_plan_shares_seeds_and_has_unique_indices():
    planned = plan_paper(5, 3)
    assert [cfg.key for cfg, _ in planned] == ["no_dvl", "unfiltered", "filtered_50"]
    seeds = [[s.seed for s in specs] for _, specs in planned]
    assert seeds[0] == seeds[1] == seeds[2]
    idx = [s.index for _, specs in planned for s in specs]
    assert sorted(idx) == list(range(15))
    a, b, c = (specs[0] for _, specs in planned)
    assert (a.scenario, a.controller) == ("pool_no_dvl", {"compensation": False})
    assert b.controller == {"compensation": True, "filter_cutoff_rad_s": None}
    assert c.controller == {"compensation": True, "filter_cutoff_rad_s": 50.0}
    assert all(s.measure == ("oscillation",) for _, specs in planned for s in specs)


def _recs(outcomes, osc):
    return [RunRecord(i, i, o, 100.0, metrics={OSC_METRIC: x, OSC_METRIC_10HZ: x}) for i, (o, x) in enumerate(zip(outcomes, osc))]


def test_verdicts_follow_the_numbers():
    assert "oscillates more" in oscillation_verdict([0.2, 0.3, 0.25], [0.01, 0.02, 0.015])
    assert "no clear difference" in oscillation_verdict([0.02, 0.02], [0.02, 0.021])
    assert "less than (c)" in oscillation_verdict([0.001], [0.02])
    assert "cannot be compared" in oscillation_verdict([math.nan], [0.1])
    lo = summarize(_recs(["success"] * 2 + ["grasp_missed"] * 28, [0.0] * 30))
    hi = summarize(_recs(["success"] * 25 + ["timeout"] * 5, [0.0] * 30))
    assert "do not overlap" in success_verdict(lo, hi)
    assert "Contrary" in success_verdict(hi, lo)
    assert "overlap" in success_verdict(lo, lo)


def test_render_contains_tables_and_command():
    groups = [
        (CONFIGS[0], _recs(["success", "not_detected", "grasp_missed", "error"], [0.01, math.nan, 0.02, math.nan])),
        (CONFIGS[1], _recs(["success", "success", "timeout", "abort"], [0.3, 0.2, 0.25, math.nan])),
        (CONFIGS[2], _recs(["success", "success", "success", "grasp_missed"], [0.02, 0.01, 0.03, 0.02])),
    ]
    groups[0][1][3].error = "ValueError: x"
    text = render_markdown(groups, runs=4, seed=0, command="maris campaign --paper --runs 4", wall_s=120.0,
                           workers="2 local worker processes", charts=("results/success.png", "results/osc.png"))
    assert "`maris campaign --paper --runs 4`" in text
    assert "| (a) no DVL | `pool_no_dvl` | compensation=False | 4 | 1 (25.0 %) |" in text
    assert "8/29 = 27.6 %" in text and "12/17 = 70.6 %" in text
    assert "| (b) DVL, unfiltered | 3 | 0.2500 | 0.2250-0.2750 | 0.25000 | 0.22500-0.27500 |" in text
    assert "![success rates](results/success.png)" in text
    assert "Paired by seed: 2 runs succeed only with (c), 0 only with (a); exact McNemar p = 0.5" in text
    assert "1 runs raised" in text and "ValueError: x" in text
    assert "Above 1 Hz: unfiltered feedback (b) oscillates more than filtered (c)" in text
    assert "(a) no DVL: 25.0 % on the simulator is consistent with the field's 27.6 %" in text
    assert "(c) DVL, 50 rad/s filter: 75.0 % on the simulator is consistent" in text


def test_paper_verdict_by_intervals():
    from mission.campaign.paper import paper_verdict

    high = summarize(_recs(["success"] * 21 + ["grasp_missed"] * 3, [0.0] * 24))
    low = summarize(_recs(["success"] * 1 + ["grasp_missed"] * 23, [0.0] * 24))
    assert "higher than the field's 27.6 %" in paper_verdict(CONFIGS[0], high)
    assert "lower than the field's 70.6 %" in paper_verdict(CONFIGS[2], low)
    assert paper_verdict(CONFIGS[1], high) is None  # no field campaign for (b)
