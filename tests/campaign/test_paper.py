"""The results page of the MARIS experiment: planning and rendering (no runs here)."""

import math

import pytest

from mission.campaign.paper import (
    CONFIG_BY_KEY,
    OSC_METRIC,
    OSC_METRIC_10HZ,
    TOOL_OSC_METRIC,
    VEHICLE_OSC_METRIC,
    oscillation_verdict,
    paper_verdict,
    plan_paper,
    ratio_verdict,
)
from mission.campaign.paper_render import render_markdown
from mission.campaign.records import RunRecord
from mission.campaign.stats import summarize_attempts


def test_plan_matches_the_field_campaigns_and_shares_seeds():
    planned = plan_paper(5, 3)
    assert [cfg.key for cfg, _ in planned] == ["oct2015", "dec2015", "apr2016_unfiltered", "apr2016"]
    seeds = [[s.seed for s in specs] for _, specs in planned]
    assert seeds[0] == seeds[1] == seeds[2] == seeds[3]
    idx = [s.index for _, specs in planned for s in specs]
    assert sorted(idx) == list(range(20))
    a, b, c, d = (specs[0] for _, specs in planned)
    assert a.mission_path.endswith("maris_arm_only_grasp.yaml") and a.scenario == "pool_oct2015"
    assert a.controller == {"compensation": False}
    assert (b.scenario, b.controller) == ("pool_dec2015", {"compensation": False})
    assert c.controller == {"compensation": True, "filter_cutoff_rad_s": None}
    assert (d.scenario, d.controller) == ("pool_apr2016", {"compensation": True, "filter_cutoff_rad_s": 50.0})
    assert all(s.mission_path.endswith("maris_pipe_recovery.yaml") for s in (b, c, d))
    assert all(s.measure == ("oscillation",) for _, specs in planned for s in specs)
    # each configuration is compared with its own field campaign
    assert [cfg.paper for cfg, _ in planned] == [(4, 16), (4, 13), None, (12, 17)]


def _rec(i, outcome, attempts, osc=0.01):
    metrics = {OSC_METRIC: osc, OSC_METRIC_10HZ: osc, VEHICLE_OSC_METRIC: osc, TOOL_OSC_METRIC: osc / 10}
    return RunRecord(
        i,
        i,
        outcome,
        100.0,
        metrics=metrics,
        attempts=[
            {"outcome": o, "t_start": 0.0, "duration_s": 10.0, "time_to_grasp_s": 20.0 if o == "success" else None}
            for o in attempts
        ],
    )


def test_verdicts_follow_the_numbers():
    assert "oscillates more" in oscillation_verdict([0.2, 0.3, 0.25], [0.01, 0.02, 0.015], "x")
    assert "no clear difference" in oscillation_verdict([0.02, 0.02], [0.02, 0.021], "x")
    assert "less than (d)" in oscillation_verdict([0.001], [0.02], "x")
    assert "no comparison" in oscillation_verdict([math.nan], [0.1], "x")
    low = summarize_attempts([_rec(0, "success", ["no_convergence"] * 9 + ["success"])])
    high = summarize_attempts([_rec(0, "success", ["success"] * 7 + ["slip"] * 3)])
    assert "met" in ratio_verdict(low, high) and "7.00 times" in ratio_verdict(low, high)
    assert "missed" in ratio_verdict(high, high)
    assert low.dominant_failure == "no_convergence"
    dec = CONFIG_BY_KEY["dec2015"]
    text = paper_verdict(dec, summarize_attempts([_rec(0, "success", ["success"] * 3 + ["no_convergence"] * 7)]))
    assert "30.0 % on the simulator, inside the field's interval 12.7-57.6 %" in text
    assert "above the field's interval" in paper_verdict(dec, high)
    assert paper_verdict(CONFIG_BY_KEY["apr2016_unfiltered"], high) is None  # no field campaign


def test_render_contains_tables_and_command():
    from mission.campaign.paper import CONFIGS

    groups = [
        (CONFIGS[0], [_rec(0, "not_detected", ["not_detected"] * 3), _rec(1, "success", ["success"])]),
        (CONFIGS[1], [_rec(2, "success", ["no_convergence", "success"]), _rec(3, "grasp_missed", ["slip"] * 3)]),
        (CONFIGS[2], [_rec(4, "success", ["success"], osc=0.05), _rec(5, "success", ["success"], osc=0.05)]),
        (CONFIGS[3], [_rec(6, "success", ["success"]), _rec(7, "error", [])]),
    ]
    groups[3][1][1].error = "ValueError: x"
    text = render_markdown(
        groups,
        runs=2,
        seed=0,
        command="maris campaign --paper --runs 2",
        wall_s=120.0,
        workers="2 local worker processes",
        charts=("results/success.png", "results/osc.png"),
    )
    assert "`maris campaign --paper --runs 2`" in text
    assert (
        "| (b) Dec 2015: coordinated, no DVL | `missions/maris_pipe_recovery.yaml` | `pool_dec2015` | "
        "compensation=False | 2 | 5 | 1 | 20.0 % |"
    ) in text
    assert "| 4/13 = 30.8 % | 12.7-57.6 % |" in text and "12/17 = 70.6 %" in text
    assert "| (a) Oct 2015: arm only, held, very turbid | 4 | 0 | 0 | 0 | 3 | 0 | 0 | not_detected |" in text
    assert "![grasp attempts](results/success.png)" in text
    assert "1 runs raised" in text and "ValueError: x" in text
    assert "Vehicle angular rate above 1 Hz (actual): unfiltered feedback (c) oscillates more" in text
    assert "With vs without DVL: per-attempt success with the DVL and filter is 5.00 times" in text
    assert "Nothing was fitted to Table I" in text
    assert (
        "filter removes it): **reproduced**. Unfiltered vs filtered, the actual vehicle rate or tool motion "
        "above 1 Hz is at most 5 times larger (above 8 Hz, where the filter acts, n/a times)" in text
    )


@pytest.mark.slow
def test_page_re_renders_from_saved_records(tmp_path):
    from mission.campaign.paper import CONFIGS
    from mission.campaign.paper_run import KEPT_MARK, RECORDS_FILE, rerender, save_records

    groups = [
        (cfg, [_rec(2 * k, "success", ["no_convergence", "success"]), _rec(2 * k + 1, "error", [])])
        for k, cfg in enumerate(CONFIGS)
    ]
    meta = {
        "runs": 2,
        "seed": 0,
        "command": "maris campaign --paper --runs 2",
        "wall_s": 60.0,
        "workers": "2 local worker processes",
        "load": 3.0,
    }
    out = tmp_path / "results.md"
    hand_written = f"{KEPT_MARK}\n\n## Vision in the loop\n\nWritten by hand.\n"
    out.write_text("# an older page\n\nold generated text\n\n" + hand_written)
    save_records(groups, meta, tmp_path / "results" / RECORDS_FILE)
    again = rerender(out)
    assert [r.attempts for r in again[1][1]] == [r.attempts for r in groups[1][1]]
    text = out.read_text()
    assert "| 2 | 2 | 1 | 50.0 % |" in text and (tmp_path / "results" / "success.png").exists()
    assert "cannot sustain an oscillation" in text and "| pitch |" in text
    assert "old generated text" not in text and text.endswith(hand_written)  # the hand-written tail is kept
