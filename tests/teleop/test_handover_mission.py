"""The shipped handover mission, end to end in a dry run with a scripted operator: the
survey misses the pipe 3 times, the operator (a recorded gamepad session) turns the
vehicle round and drives until the pipe is seen, which hands control back, and the grasp
is autonomous. A replay of the run's log is identical, the operator's inputs included."""

from __future__ import annotations

from pathlib import Path

import pytest

import mission.replay.record  # noqa: F401 - registers the input record
from mission.logs.reader import read_log
from mission.replay.run import replay_log
from mission.runtime.api import run_mission
from mission.runtime.options import RunOptions, RunTarget

ROOT = Path(__file__).resolve().parents[2]


@pytest.mark.slow
def test_the_handover_mission_runs_end_to_end_and_replays_identically(tmp_path):
    log_path = tmp_path / "handover.mcap"
    result = run_mission(
        RunTarget(ROOT / "missions" / "pipe_recovery_handover.yaml", scenario="pool_handover", seed=1),
        RunOptions(log_path=log_path),
    )
    assert result.outcome == "succeeded", result.failure_cause
    assert result.grasp == "holding"
    events = read_log(log_path).messages("/events")
    surveys = [e for e in events if e["kind"] == "attempt_failed" and "Survey" in e["message"]]
    assert len(surveys) == 3
    control = [e for e in events if e["kind"] == "control"]
    assert [e["fields"]["who"] for e in control] == ["operator", "autonomy"]
    assert "detected" in control[1]["message"]  # the pipe in view gave control back
    assert control[0]["t"] > surveys[-1]["t"] - 1e-9
    actions = [a for _, a in result.actions]
    assert actions.index("jog_vehicle") < actions.index("grasp")
    teleop = read_log(log_path).messages("/operator/teleop")
    assert {m["input"] for m in teleop if m["control"] == "operator"} >= {"gamepad"}
    report = replay_log(log_path)
    assert report.identical, report.comparison.first and report.comparison.first.describe()
    assert report.comparison.counts["/operator/teleop"] == len(teleop)
    reads = {r["call"] for m in read_log(log_path).messages("/replay/steps") for s in m["steps"] for r in s["reads"]}
    assert {"gamepad.latest", "foxglove.latest", "keyboard.latest"} <= reads
