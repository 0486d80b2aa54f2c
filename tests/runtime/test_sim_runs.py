"""End-to-end dry runs: the real simulator, KCL, compiled mission tree and logs."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time

import pytest
from mcap.reader import NonSeekingReader

from mission.cli import main
from mission.logs.reader import read_log
from mission.runtime.api import run_mission
from mission.runtime.options import RunHooks, RunOptions, RunTarget

from .conftest import REFERENCE, ROOT, SCENARIO


@pytest.mark.slow
def test_reference_mission_succeeds(reference_run):
    code, out, log_path = reference_run
    assert code == 0, out
    assert "outcome:   succeeded" in out
    log = read_log(log_path)
    assert not log.truncated
    result = log.result
    assert result["outcome"] == "succeeded" and result["grasp"] == "holding"
    actions = [a for _, a in result["actions"]]
    assert actions[:3] == ["transport", "survey", "grasp"] and actions[-1] == "transport"
    states = [m["state"] for m in log.messages("/supervisor/state")]
    assert states == ["preflight", "running", "succeeded"]
    assert log.messages("/tree") and log.messages("/kcl")[-1]["tasks"]


@pytest.mark.slow
def test_reference_mission_succeeds_for_another_seed():
    result = run_mission(RunTarget(REFERENCE, scenario=SCENARIO, seed=2))
    assert result.outcome == "succeeded", result.failure_cause
    assert result.grasp == "holding" and result.actions[-1][1] == "transport"
    assert result.metrics["fault_count"] == 0
    assert result.metrics["closest_to_limits"]["joint_limits_rad"] > 0
    # no log written, yet the truth-based metrics and simulator events are there
    assert result.log_path is None and result.metrics["min_tool_to_target_m"] < 0.05
    assert any(e.kind == "sim" and "grasp" in e.message for e in result.events)


#: Wall-clock metrics of the result beside the ``wall_*`` ones.
WALL_CLOCK_METRICS = ("realtime_factor", "phase_wall_s")


@pytest.mark.slow
def test_rerun_with_same_seed_is_identical(reference_run, tmp_path):
    """Same mission, scenario and seed: the same log, message for message
    (only the wall-clock figures of the result differ)."""
    _, _, first_log = reference_run
    again = run_mission(RunTarget(REFERENCE, scenario=SCENARIO, seed=1), RunOptions(log_path=tmp_path / "again.mcap"))
    assert again.outcome == "succeeded"
    a, b = read_log(first_log), read_log(tmp_path / "again.mcap")
    assert set(a.topics) == set(b.topics)
    for topic in a.topics:
        if topic == "/run/result":
            for m in a.messages(topic) + b.messages(topic):
                for key in [k for k in m["metrics"] if k in WALL_CLOCK_METRICS or k.startswith("wall_")]:
                    m["metrics"].pop(key)
        assert a.messages(topic) == b.messages(topic), topic


@pytest.mark.slow
def test_log_summary_repeats_the_end_of_run_summary(reference_run, capsys):
    """`maris log summary` shows the figures printed at the end of `maris sim`
    (closest approaches at the full loop rate, final ground truth), not the
    coarser figures recomputed from the decimated log channels."""
    _, out, log_path = reference_run
    assert main(["log", "summary", str(log_path)]) == 0
    summary = capsys.readouterr().out.strip()
    assert "closest approach to limits" in summary
    assert summary in out, (summary, out[-1500:])


@pytest.mark.slow
def test_log_plot_command_writes_pngs(reference_run, tmp_path):
    _, _, log_path = reference_run
    assert main(["log", "plot", str(log_path), "--out", str(tmp_path / "plots")]) == 0
    pngs = sorted(p.name for p in (tmp_path / "plots").glob("*.png"))
    assert pngs == ["joint_velocities.png", "task_activations.png", "tool_to_target.png", "vehicle_velocity.png"]


@pytest.mark.slow
def test_pause_and_resume(tmp_path):
    path = tmp_path / "pause.mcap"
    result = run_mission(
        RunTarget(REFERENCE, scenario=SCENARIO, seed=1),
        RunOptions(log_path=path),
        RunHooks(operator_script=[(12.0, "pause"), (16.0, "resume"), (24.0, "stop_now")]),
    )
    assert result.outcome == "aborted" and "operator" in result.failure_cause
    log = read_log(path)
    states = [(m["t"], m["state"]) for m in log.messages("/supervisor/state")]
    assert [s for _, s in states] == ["preflight", "running", "paused", "running", "aborting", "aborted"]
    t_pause, t_resume = states[2][0], states[3][0]
    assert 12.0 <= t_pause < 12.2 and 16.0 <= t_resume < 16.2
    during = [m for m in log.messages("/vehicle/command") if t_pause < m["t"] < t_resume]
    assert during and all(not any(m["body_velocity"]) for m in during)
    arm = [m for m in log.messages("/arm/command") if t_pause < m["t"] < t_resume]
    assert arm and all(not any(m["velocity"]) for m in arm)
    kcl = log.messages("/kcl")
    before = [m["action"] for m in kcl if m["t"] < t_pause]
    after_resume = [m["action"] for m in kcl if m["t"] > t_resume]
    assert before[-1] and after_resume[0] == before[-1]  # the action running at the pause is resumed
    after = [m for m in log.messages("/arm/command") if t_resume + 0.5 < m["t"] < 23.9]
    assert any(any(m["velocity"]) for m in after)
    assert not any(log.messages("/vehicle/command")[-1]["body_velocity"])


@pytest.mark.slow
def test_nan_attitude_stops_motion_at_once(tmp_path):
    """A non-finite AHRS output skips the abort path: immediate safe stop."""
    path = tmp_path / "nan.mcap"
    result = run_mission(
        RunTarget(REFERENCE, scenario=SCENARIO, seed=1),
        RunOptions(log_path=path),
        RunHooks(on_supervisor=lambda sup: sup.backend.inject("ahrs_nan", start=5.0)),
    )
    assert result.outcome == "aborted" and result.failure_cause.startswith("non_finite")
    log = read_log(path)
    assert [m["state"] for m in log.messages("/supervisor/state")][-2:] == ["aborting", "aborted"]
    t_stop = next(m["t"] for m in log.messages("/supervisor/state") if m["state"] == "aborting")
    assert 5.0 <= t_stop < 5.1
    assert all(not any(m["velocity"]) for m in log.messages("/arm/command") if m["t"] > t_stop)
    assert result.duration_s < t_stop + 5.0


def test_drive_fault_before_start_fails_preflight():
    result = run_mission(
        RunTarget(REFERENCE, scenario=SCENARIO, seed=1),
        RunOptions(),
        RunHooks(on_supervisor=lambda sup: sup.backend.inject("joint_fault", joint=1)),
    )
    assert result.outcome == "failed" and result.failure_cause.startswith("preflight")
    assert "arm" in result.failure_cause and result.duration_s <= 2.1


@pytest.mark.slow
def test_dvl_dropout_trips_watchdog_and_runs_abort_path(tmp_path):
    path = tmp_path / "dvl.mcap"
    result = run_mission(
        RunTarget(REFERENCE, scenario=SCENARIO, seed=1, overrides={"dvl.dropouts": [[15.0, 10000.0]]}),
        RunOptions(log_path=path),
    )
    assert result.outcome == "aborted"
    assert "watchdog" in result.failure_cause and "dvl_velocity" in result.failure_cause
    kinds = [e.kind for e in result.events]
    assert "abort_path" in kinds and kinds.index("watchdog") < kinds.index("abort_path")
    log = read_log(path)
    assert [m["state"] for m in log.messages("/supervisor/state")][-2:] == ["aborting", "aborted"]
    trip = next(m["t"] for m in log.messages("/events") if m["kind"] == "watchdog")
    assert 15.0 < trip < 17.0
    assert any(m["tip"] for m in log.messages("/tree") if m["t"] > trip)
    assert result.metrics["final_vehicle_speed"] < 0.1  # braking from survey speed (full model: ~3 s, some overshoot)
    assert result.metrics["final_vehicle_rate"] < 0.03
    last_cmd = log.messages("/vehicle/command")[-1]
    assert not any(last_cmd["body_velocity"])


@pytest.mark.slow
def test_sigkill_mid_run_leaves_readable_log(tmp_path):
    path = tmp_path / "killed.mcap"
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    proc = subprocess.Popen(
        [
            sys.executable,
            "-m",
            "mission.cli",
            "sim",
            str(REFERENCE),
            "--scenario",
            SCENARIO,
            "--seed",
            "1",
            "--log",
            str(path),
        ],
        stdout=subprocess.PIPE,
        stderr=subprocess.DEVNULL,
        text=True,
        env=env,
        cwd=ROOT,
    )
    try:
        seen = None
        for line in proc.stdout:
            if line.startswith("t=") and float(line.split()[0][2:] or line.split()[1]) >= 10.0:
                seen = line
                break
        assert seen, "no progress line reached t=10 s"
        time.sleep(0.7)  # the writer flushes every 0.5 s of wall time: give it a full period
    finally:
        proc.send_signal(signal.SIGKILL)
        proc.wait(timeout=10)
    assert proc.returncode == -signal.SIGKILL
    msgs = []
    with open(path, "rb") as f:
        try:
            for _s, ch, m in NonSeekingReader(f).iter_messages(log_time_order=False):
                if ch.message_encoding == "json":  # the Foxglove channels are protobuf
                    msgs.append((ch.topic, json.loads(m.data)))
        except Exception:  # noqa: BLE001 - the cut-off end
            pass
    topics = {t for t, _ in msgs}
    assert {"/run/config", "/run/source", "/kcl", "/vehicle/command"} <= topics
    last_t = max(m["t"] for _, m in msgs)
    assert last_t >= 10.0
    assert read_log(path).truncated
