"""Safety breaches on the simulator with small variants of the shipped survey mission."""

from __future__ import annotations

import pytest

from mission.logs.reader import read_log
from mission.runtime.api import run_mission
from mission.runtime.options import RunHooks, RunOptions, RunTarget

from .conftest import ROOT

SURVEY = (ROOT / "missions" / "survey_only.yaml").read_text()


def variant(tmp_path, name: str, text: str):
    path = tmp_path / f"{name}.yaml"
    path.write_text(text)
    return path


@pytest.mark.slow
def test_geofence_breach_runs_the_abort_path(tmp_path):
    text = SURVEY.replace("geofence: {north_m: [0, 25]", "geofence: {north_m: [0, 10]")
    assert text != SURVEY
    log_path = tmp_path / "fence.mcap"
    result = run_mission(
        RunTarget(variant(tmp_path, "fence", text), scenario="pool_fixed", seed=3, overrides={"pipe.x_m": 21.0}),
        RunOptions(log_path=log_path),
    )  # far beyond the fence: not seen before it
    assert result.outcome == "aborted"
    assert result.failure_cause.startswith("envelope (geofence_m)")
    log = read_log(log_path)
    trip = next(m for m in log.messages("/events") if m["kind"] == "envelope")
    nav_at_trip = [m for m in log.messages("/vehicle/navigation") if m["t"] <= trip["t"]][-1]
    assert nav_at_trip["position"][0] > 9.8  # caught within a few cm of the fence
    assert any(m["kind"] == "abort_path" for m in log.messages("/events"))
    assert result.metrics["closest_to_limits"]["geofence_m"] < 0


@pytest.mark.slow
def test_drive_fault_during_the_abort_path_stops_at_once(tmp_path):
    """The abort path moves the vehicle; a drive fault then is unsafe: safe stop now."""
    text = SURVEY.replace("geofence: {north_m: [0, 25]", "geofence: {north_m: [0, 10]")
    log_path = tmp_path / "fault.mcap"
    result = run_mission(
        RunTarget(variant(tmp_path, "fault", text), scenario="pool_fixed", seed=3, overrides={"pipe.x_m": 21.0}),
        RunOptions(log_path=log_path),
        RunHooks(on_supervisor=lambda sup: sup.backend.inject("joint_fault", start=11.0, joint=0)),
    )
    assert result.outcome == "aborted" and result.failure_cause.startswith("envelope (geofence_m)")
    log = read_log(log_path)
    t_abort = next(m["t"] for m in log.messages("/supervisor/state") if m["state"] == "aborting")
    assert t_abort < 11.0
    ends = [m for m in log.messages("/events") if m["kind"] == "abort"]
    assert len(ends) == 1 and ends[0]["message"].startswith("safe stop: drive_fault")
    assert 11.0 <= ends[0]["t"] < 11.2
    assert all(not any(m["body_velocity"]) for m in log.messages("/vehicle/command") if m["t"] >= ends[0]["t"])
    assert result.metrics["final_vehicle_speed"] < 0.1  # braking from survey speed (full model: ~3 s, some overshoot)


@pytest.mark.slow
def test_software_error_stops_motion_and_ends_failed(tmp_path):
    """An exception inside the loop (here: the KCL, made to throw at t >= 5 s)
    still leaves the vehicle stopped, the log complete, and a clear cause."""

    def sabotage(sup):
        real_step = sup.controller.vehicle_step

        def failing_step(meas, t):
            if t >= 5.0:
                raise RuntimeError("boom")
            return real_step(meas, t)

        sup.controller.vehicle_step = failing_step

    log_path = tmp_path / "bug.mcap"
    result = run_mission(
        RunTarget(ROOT / "missions" / "survey_only.yaml", scenario="pool_fixed", seed=3, overrides={"pipe.x_m": 21.0}),
        RunOptions(log_path=log_path),
        RunHooks(on_supervisor=sabotage),
    )
    assert result.outcome == "failed" and result.failure_cause == "internal error: RuntimeError: boom"
    event = next(e for e in result.events if e.kind == "internal_error")
    assert "failing_step" in event.fields["traceback"]
    log = read_log(log_path)
    assert not log.truncated and log.result["outcome"] == "failed"
    assert not any(log.messages("/vehicle/command")[-1]["body_velocity"])
    assert result.metrics["final_vehicle_speed"] < 0.1  # braking from survey speed (full model: ~3 s, some overshoot)


def test_non_finite_kcl_output_never_reaches_the_devices(tmp_path):
    """A KCL that outputs NaN (made to, from t >= 5 s): the command is not sent,
    motion stops at once, the run ends aborted."""

    def poison(sup):
        real_step = sup.controller.arm_step

        def nan_step(meas, t):
            out = real_step(meas, t)
            return out * float("nan") if t >= 5.0 else out

        sup.controller.arm_step = nan_step

    log_path = tmp_path / "nan_kcl.mcap"
    result = run_mission(
        RunTarget(ROOT / "missions" / "survey_only.yaml", scenario="pool_fixed", seed=3, overrides={"pipe.x_m": 21.0}),
        RunOptions(log_path=log_path),
        RunHooks(on_supervisor=poison),
    )
    assert result.outcome == "aborted" and result.failure_cause.startswith("non_finite (controller)")
    log = read_log(log_path)
    arm_cmds = log.messages("/arm/command")
    assert all(None not in m["velocity"] for m in arm_cmds)  # NaN would be logged as null
    assert all(not any(m["velocity"]) for m in arm_cmds if m["t"] >= 5.0)
    assert result.metrics["final_vehicle_speed"] < 0.1  # braking from survey speed (full model: ~3 s, some overshoot)
