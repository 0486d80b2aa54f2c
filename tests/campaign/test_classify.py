"""Failure-cause classification from the supervisor's RunResult."""

import pytest

from mission.campaign.classify import classify
from mission.runtime.supervisor import RunResult

SURVEY = [(0.0, "transport"), (5.0, "survey")]
GRASP = SURVEY + [(60.0, "grasp")]


@pytest.mark.parametrize(
    "result, expected",
    [
        (RunResult("succeeded", 100.0, None, "holding", actions=GRASP + [(90.0, "transport")]), "success"),
        (RunResult("succeeded", 100.0, None, None, actions=SURVEY), "success"),  # survey-only mission
        (RunResult("succeeded", 100.0, None, "none", actions=GRASP), "grasp_missed"),
        (
            RunResult(
                "aborted",
                900.0,
                "envelope (duration_s): mission duration limit exceeded (margin -0.010)",
                "none",
                actions=GRASP + [(899.0, "hold")],
            ),
            "timeout",
        ),
        (RunResult("failed", 50.0, "run time cap of 50 s reached", None, actions=SURVEY), "timeout"),
        (RunResult("aborted", 20.0, "watchdog (navigation): no reading for 0.6 s", None, actions=SURVEY), "abort"),
        (RunResult("aborted", 20.0, "non_finite (arm): NaN in joint positions", None, actions=GRASP), "abort"),
        (RunResult("failed", 1.0, "preflight: arm not ready", None), "abort"),
        (RunResult("aborted", 9.0, "operator abort (signal)", None, actions=SURVEY), "abort"),
        (
            RunResult(
                "failed",
                310.0,
                "mission failed at Survey until the pipe is seen",
                None,
                actions=SURVEY + [(305.0, "hold")],
            ),
            "not_detected",
        ),
        (
            RunResult(
                "failed", 73.0, "mission failed at Fold the arm", None, actions=[(0.0, "transport"), (60.1, "hold")]
            ),
            "abort",
        ),
        (
            RunResult(
                "failed", 400.0, "mission failed at Grasp, up to 3 attempts", "none", actions=GRASP + [(399.0, "hold")]
            ),
            "grasp_missed",
        ),
    ],
)
def test_categories(result, expected):
    assert classify(result) == expected


def test_deterministic_metrics_drop_wall_clock_figures():
    from mission.campaign.single import deterministic_metrics

    m = deterministic_metrics(
        {
            "wall_s": 6.2,
            "realtime_factor": 11.8,
            "phase_wall_s": {"kcl": 3.7},
            "steps": 7320,
            "closest_to_limits": {"depth_m": 8.35},
            "min_tool_to_target_m": None,
            "ok": True,
            "name": "x",
        }
    )
    assert m == {"steps": 7320.0, "closest_to_limits.depth_m": 8.35, "ok": 1.0}
