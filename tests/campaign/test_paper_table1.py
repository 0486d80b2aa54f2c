"""The results page's comparison with Table I (mission.campaign.paper_table1)."""

import math

import pytest

from mission.campaign.paper import ARM_ONLY_MISSION, CONFIG_BY_KEY, REFERENCE_MISSION
from mission.campaign.paper_table1 import contact_margins, grasp_retries, mission_rate, table1_section, verdict
from mission.campaign.records import RunRecord
from mission.campaign.stats import summarize, summarize_attempts


def _rec(i, outcome, attempts, contact=None):
    return RunRecord(
        i,
        i,
        outcome,
        100.0,
        attempts=[
            {
                "outcome": o,
                "t_start": 0.0,
                "duration_s": 10.0,
                "time_to_grasp_s": 20.0 if o == "success" else None,
                **({"contact": contact} if contact else {}),
            }
            for o in attempts
        ],
    )


def test_both_missions_allow_three_attempts():
    assert grasp_retries(REFERENCE_MISSION) == 3
    assert grasp_retries(ARM_ONLY_MISSION) == 3


def test_mission_rate_and_verdict():
    assert mission_rate(0.5, 3) == pytest.approx(0.875)
    assert mission_rate(0.0, 3) == 0.0 and mission_rate(1.0, 1) == 1.0
    assert verdict(0.3, (0.127, 0.576)) == "matched"
    assert verdict(1.0, (0.469, 0.867)) == "missed (above)"
    assert verdict(0.01, (0.102, 0.495)) == "missed (below)"


def test_contact_margins_is_a_fraction_of_the_tolerance():
    from sim_backend.scenario import load_scenario

    tol = load_scenario("pool_apr2016").values["grasp.across_tolerance_m"]
    recs = [_rec(0, "success", ["success"], contact={"across_m": -0.5 * tol, "approach_m": 0.0})]
    assert contact_margins(recs, "pool_apr2016") == pytest.approx((0.5, 0.5))
    assert all(math.isnan(x) for x in contact_margins([_rec(1, "success", ["success"])], "pool_apr2016"))


def test_section_compares_each_campaign_with_its_configuration():
    recs = {
        "oct2015": [_rec(0, "grasp_missed", ["not_detected"] * 3), _rec(1, "grasp_missed", ["not_detected"])],
        "dec2015": [_rec(2, "success", ["no_convergence", "success"]), _rec(3, "grasp_missed", ["no_convergence"] * 3)],
        "apr2016": [_rec(4, "success", ["success"], contact={"across_m": 0.001, "approach_m": 0.001})] * 2,
    }
    att = {k: summarize_attempts(v) for k, v in recs.items()}
    mis = {k: summarize(v) for k, v in recs.items()}
    text = "\n".join(table1_section(CONFIG_BY_KEY, att, mis, recs))
    # Dec 2015: 1/5 = 20 % per attempt, inside 12.7-57.6 %; per mission 1/2 against 1-(1-4/13)^3
    assert "| Dec 2015 | (b) | 4/13 = 30.8 % (12.7-57.6 %) | 1/5 = 20.0 % (" in text
    assert f"{100 * mission_rate(4 / 13, 3):.1f} %" in text
    assert "| **matched** |" in text and "**missed (above)**" in text
    assert "dominant `no_convergence`, as in the paper" in text
    assert "Oct 2015: missed (below)" in text and "4.5 m visibility" in text
    assert "in one attempt out of ten" in text
    assert "Oct 2015: missed (below) (the two intervals overlap)" in text
    assert "The paper gives no mission counts" in text
