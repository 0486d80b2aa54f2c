"""`maris log replay` on real dry runs: identical at every step (bit for bit,
this machine), a changed controller setting diverges at the step where a live
run with that setting first commands something else, a log cut short replays
up to its end, and an open-loop what-if with a changed mission reports and
plots what changed."""

from __future__ import annotations

import json
import re

import pytest

from mission.cli import main
from mission.replay.compare import COMMANDS
from mission.replay.rawlog import RawLog
from mission.replay.run import replay_log
from mission.replay.settings import NO_FILTER_CUTOFF_RAD_S
from mission.runtime.api import run_mission
from mission.runtime.options import RunHooks, RunOptions, RunTarget
from mission.runtime.result import SupervisorOptions

from .conftest import REFERENCE, SCENARIO


def first_command_difference(a_path, b_path) -> int:
    """First step at which two logs' commands differ (an independent oracle)."""
    a = RawLog(a_path).steps()
    b = RawLog(b_path).steps()
    for s, (x, y) in enumerate(zip(a, b)):
        if x["commands"] != y["commands"]:
            return s
    raise AssertionError("the runs never differ")


def cut_copy(log_path, tmp_path, fraction: float = 0.4):
    """The reference log as if the run had been killed part way (a file cut short)."""
    data = log_path.read_bytes()
    cut = tmp_path / "cut.mcap"
    cut.write_bytes(data[: int(len(data) * fraction)])
    return cut


@pytest.mark.slow
def test_reference_dry_run_replays_bit_for_bit(reference_run, capsys):
    _, _, log_path = reference_run
    assert main(["log", "replay", str(log_path)]) == 0
    out = capsys.readouterr().out
    assert "identical: every command and device call at each of" in out and "bit for bit" in out
    assert "outcome: succeeded" in out


@pytest.mark.slow
def test_dvl_dropout_and_operator_pause_replay_identically(tmp_path):
    log_path = tmp_path / "dropout.mcap"
    result = run_mission(
        RunTarget(REFERENCE, scenario=SCENARIO, seed=1),
        RunOptions(log_path=log_path),
        RunHooks(
            operator_script=[(3.0, "pause"), (4.5, "resume")],
            on_supervisor=lambda sup: sup.backend.inject("dvl_dropout", start=7.0, duration=4.0),
        ),
    )
    assert result.outcome == "aborted" and result.failure_cause.startswith("watchdog (dvl_velocity)")
    log = RawLog(log_path)
    reads = [r for m in log.steps() for r in m["reads"]]
    drains = [r["commands"][0]["command"] for r in reads if r["call"] == "operator.drain"]
    assert drains == ["pause", "resume"]
    stale = [r for r in reads if r["call"] == "vehicle.navigation" and r["t"] - r["velocity_t"] > 0.9]
    assert stale  # the dropout: the DVL velocity stops being refreshed
    report = replay_log(log_path)
    assert report.identical, report.comparison.first and report.comparison.first.describe()
    assert report.replay_outcome == "aborted" and report.replay_cause == result.failure_cause
    assert report.comparison.counts["/supervisor/state"] == 6  # running, paused, running, aborting, aborted...


def test_non_finite_attitude_run_replays_identically(tmp_path):
    """NaN readings cannot go into JSON as numbers: they come back exactly anyway."""
    log_path = tmp_path / "nan.mcap"
    result = run_mission(
        RunTarget(REFERENCE, scenario=SCENARIO, seed=1),
        RunOptions(log_path=log_path),
        RunHooks(on_supervisor=lambda sup: sup.backend.inject("ahrs_nan", start=2.0)),
    )
    assert result.failure_cause.startswith("non_finite")
    assert any("nonfinite" in r for m in RawLog(log_path).steps() for r in m["reads"])
    assert replay_log(log_path).identical


@pytest.mark.slow
def test_changed_setting_diverges_at_the_step_a_live_run_does(reference_run, tmp_path, capsys):
    """Closed loop, the world only reacts to commands: a live run with the setting
    sees the same inputs up to its first different command, so that is the step
    the open-loop replay must name. (Both runs cut at about 27 s to save time.)"""
    log_path = cut_copy(reference_run[2], tmp_path, 0.5)
    live = tmp_path / "unfiltered.mcap"
    run_mission(
        RunTarget(REFERENCE, scenario=SCENARIO, seed=1),
        RunOptions(log_path=live, filter_cutoff=NO_FILTER_CUTOFF_RAD_S, supervisor=SupervisorOptions(max_time_s=24.0)),
    )
    expected = first_command_difference(log_path, live)
    assert expected > 0
    code = main(["log", "replay", str(log_path), "--set", "controller.filter_cutoff_rad_s=.inf", "--json"])
    assert code == 0  # a what-if that ran
    report = json.loads(capsys.readouterr().out)
    assert report["whatif"] and not report["identical"]
    commands = [d for d in report["divergences"] if d["channel"] == COMMANDS]
    assert commands[0]["step"] == expected, (commands, expected)
    assert report["first_divergence"]["step"] <= expected  # the KCL's own state may show it earlier
    arm = report["summary"]["commands"]["arm.command_joint_velocity"]
    assert arm["steps_different"] > 0 and max(arm["max_abs_diff"]) > 1e-3


@pytest.mark.slow
def test_log_cut_short_replays_up_to_its_end(reference_run, tmp_path, capsys):
    cut = cut_copy(reference_run[2], tmp_path)
    assert main(["log", "replay", str(cut)]) == 0
    out = capsys.readouterr().out
    assert "the log was cut short: replayed and compared up to its last complete step" in out
    assert "identical" in out


@pytest.mark.slow
def test_whatif_with_a_changed_mission_reports_and_plots(reference_run, tmp_path, capsys):
    log_path = cut_copy(reference_run[2], tmp_path, 0.5)  # the first 25 s or so: shorter, and cut short too
    # the survey's detection threshold raised to 0.99, whatever the reference mission's is
    text = re.sub(
        r"until: \{detected: \{min_confidence: [0-9.]+,",
        "until: {detected: {min_confidence: 0.99,",
        REFERENCE.read_text(),
    )
    assert "0.99" in text
    changed = tmp_path / "picky.yaml"
    changed.write_text(text)
    plots = tmp_path / "plots"
    code = main(
        [
            "log",
            "replay",
            str(log_path),
            "--mission",
            str(changed),
            "--plot",
            str(plots),
            "--out",
            str(tmp_path / "w.mcap"),
        ]
    )
    out = capsys.readouterr().out
    assert code == 0, out
    assert "what-if: mission" in out and "open loop" in out and "the world does not react" in out
    assert "actions started:\n    log:     transport@0.0s  survey@" in out  # the what-if never leaves the survey
    assert "grasp" not in out.split("what-if: ")[-1].split("\n")[0]
    assert sorted(p.name for p in plots.glob("*.png")) == [
        "replay_joint_references.png",
        "replay_reference_differences.png",
        "replay_vehicle_references.png",
    ]
    assert RawLog(tmp_path / "w.mcap").messages("/replay/header")


@pytest.mark.slow
def test_replay_refuses_what_it_cannot_do(reference_run, tmp_path, capsys):
    from mission.logs.writer import RunLogWriter

    old = tmp_path / "old.mcap"
    with RunLogWriter(old) as w:
        w.write("/run/config", 0.0, {"mission_path": "m.yaml"})
    assert main(["log", "replay", str(old)]) == 2
    assert "has no input record" in capsys.readouterr().err
    _, _, log_path = reference_run
    assert main(["log", "replay", str(log_path), "--set", "controller.gain=2"]) == 2
    assert "--set:1:1: controller.gain: unknown setting" in capsys.readouterr().err
    assert main(["log", "replay", str(tmp_path / "missing.mcap")]) == 2
    assert "cannot open" in capsys.readouterr().err
