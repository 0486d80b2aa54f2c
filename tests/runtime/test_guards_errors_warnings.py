"""Runs of issue 16: a guard on a numpy-valued reading trips into the abort
path; a leaf that raises ends in the abort path; a missing altitude (no DVL),
an arm below the floor and the mission's lint warnings reach the summary."""

from __future__ import annotations

import numpy as np
import pytest

from mission.runtime.api import run_mission
from mission.runtime.options import RunTarget
from mission.runtime.report import format_result

HEAD = """\
name: t
safety:
  max_depth_m: 4.0
  min_altitude_m: 0.5
  max_duration_s: 30
  geofence: {north_m: [0, 25], east_m: [0, 12], down_m: [0, 4]}
abort:
  sequence:
    children:
      - log: {message: "abort path ran"}
      - action: {run: hold, until: converged, timeout_s: 2}
"""


def run(tmp_path, tree: str, extra: str = "", scenario: str | None = None):
    path = tmp_path / "m.yaml"
    path.write_text(HEAD + "tree:\n" + tree + extra)
    return run_mission(RunTarget(path, scenario=scenario))


def kinds(result, level=None):
    return [e.kind for e in result.events if level is None or e.level == level]


def test_predicates_return_plain_bools_for_numpy_readings():
    from behaviours.predicates import PredicateEval

    class Nav:
        altitude = np.float64(2.0)
        depth = np.float64(1.5)

    class Ctx:
        class devices:
            class vehicle:
                @staticmethod
                def navigation():
                    return Nav()

    for kind, params in (("altitude_m", {"min": 0.1, "max": 1.0}), ("depth_m", {"min": 1.0, "max": None})):
        ok, _ = PredicateEval(kind, params).holds(Ctx())
        assert type(ok) is bool


@pytest.mark.parametrize("condition", ["{altitude_m: {min: 0.1, max: 1.0}}", "{depth_m: {max: 0.2}}"])
def test_a_tripping_guard_runs_the_abort_path(tmp_path, condition):
    result = run(tmp_path, f"  guard:\n    condition: {condition}\n    child: {{wait: {{duration_s: 5}}}}\n")
    assert result.outcome == "failed" and result.failure_cause.startswith("mission failed at")
    assert "guard_failed" in kinds(result) and "abort_path" in kinds(result)
    assert "internal_error" not in kinds(result)
    assert any(e.message == "abort path ran" for e in result.events)


def test_a_leaf_that_raises_ends_in_the_abort_path(tmp_path, monkeypatch):
    from behaviours.wait import Wait

    def boom(self):
        raise RuntimeError("boom in a leaf")

    monkeypatch.setattr(Wait, "update", boom)
    result = run(tmp_path, "  sequence:\n    children:\n      - log: {message: start}\n      - wait: {duration_s: 1}\n")
    assert result.outcome == "failed" and result.failure_cause == "internal error: RuntimeError: boom in a leaf"
    assert kinds(result, "fault") == ["internal_error"]
    assert "abort_path" in kinds(result) and any(e.message == "abort path ran" for e in result.events)
    assert result.events[-1].kind == "abort" and "abort path ended" in result.events[-1].message


def test_no_dvl_altitude_floor_warning_at_preflight_and_in_the_summary(tmp_path):
    result = run(tmp_path, "  wait: {duration_s: 0.5}\n", scenario="pool_no_dvl")
    assert result.outcome == "succeeded"
    (ev,) = [e for e in result.events if e.kind == "altitude_floor"]
    assert ev.level == "warning" and "NOT enforced" in ev.message
    text = format_result(result)
    assert "warnings (1):" in text and "altitude floor min_altitude_m 0.5 m is NOT enforced" in text


def test_with_a_dvl_no_altitude_warning(tmp_path):
    result = run(tmp_path, "  wait: {duration_s: 0.5}\n")
    assert "altitude_floor" not in kinds(result) and "warnings (" not in format_result(result)


def test_lint_warnings_reach_the_run_summary(tmp_path):
    result = run(tmp_path, "  wait: {duration_s: 0.5}\n", "subtrees:\n  spare: {wait: {duration_s: 1}}\n")
    (ev,) = [e for e in result.events if e.kind == "lint"]
    assert "subtree `spare` is never used" in ev.message and ev.fields.get("summary")
    assert "lint: mission check:" in format_result(result)


def test_arm_below_the_floor_is_a_summary_warning():
    from mission.runtime.context import EventSink
    from mission.runtime.recorder import RunRecorder
    from mission.runtime.truth import TruthTracker

    class Backend:
        def ground_truth(self):
            return {"events": [{"t": 1.0, "event": "arm_below_floor", "depth_m": 4.12}, {"t": 2.0, "event": "grasp"}]}

    class Clock:
        def now(self):
            return 2.0

    sink = EventSink(Clock())
    TruthTracker(Backend(), sink, RunRecorder(None)).sample(2.0)
    below, grasp = sink.events
    assert (
        below.level == "warning"
        and below.fields["summary"]
        and "collision" in below.message
        and "4.12 m" in below.message
    )
    assert grasp.level == "info" and grasp.message == "simulator: grasp"
