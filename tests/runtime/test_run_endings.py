"""How simulated runs end (docs/faults.md): stop before engagement, a gripper
fault that only fails its leaf, one event per fault, the final zero command in
the log, library warnings in the run log, joints checked against the model."""

from __future__ import annotations

import logging

import pytest

from mission.logs.reader import read_log
from mission.runtime.api import run_mission
from mission.runtime.operator import CommandQueue
from mission.runtime.options import RunHooks, RunOptions, RunTarget
from mission.runtime.result import SupervisorOptions

from .conftest import REFERENCE, SCENARIO

GRIPPER_MISSION = """\
version: 1
name: gripper_fallback
rates: {tree_hz: 10, vehicle_hz: 10, arm_hz: 100}
safety:
  max_depth_m: 10.0
  min_altitude_m: 0.2
  max_duration_s: 60
  geofence: {north_m: [-30, 30], east_m: [-30, 30], down_m: [0, 10]}
tree:
  selector:
    name: Close or go on
    children:
      - gripper: {command: close, current_limit_a: 0.5, timeout_s: 5}
      - log: {message: "gripper failed: going on without it", level: warning}
abort:
  action: {name: Hold still, run: hold, timeout_s: 2}
"""


class LateAbort(CommandQueue):
    """An operator abort that arrives after ``after`` drains (e.g. Ctrl-C during the preflight)."""

    def __init__(self, after: int) -> None:
        super().__init__()
        self.after = after

    def drain(self) -> list[tuple[str, str]]:
        self.after -= 1
        if self.after == 0:
            self.put("abort", "signal SIGINT")
        return super().drain()


def spy_engage(calls: list):  # noqa: ANN201
    def hook(sup) -> None:  # noqa: ANN001
        arm_vehicle, enable_arm = sup.devices.vehicle.arm, sup.devices.arm.enable
        sup.devices.vehicle.arm = lambda: (calls.append("arm vehicle"), arm_vehicle())[1]
        sup.devices.arm.enable = lambda: (calls.append("enable drives"), enable_arm())[1]

    return hook


def test_stop_before_engagement_engages_nothing(tmp_path) -> None:  # noqa: ANN001
    calls: list = []
    queue = CommandQueue()
    queue.put("abort", "signal SIGINT")  # Ctrl-C right after launch
    result = run_mission(
        RunTarget(REFERENCE, scenario=SCENARIO, seed=1),
        RunOptions(log_path=tmp_path / "a.mcap"),
        RunHooks(commands=queue, on_supervisor=spy_engage(calls)),
    )
    assert result.outcome == "aborted" and result.failure_cause == "operator stop before engagement (signal SIGINT)"
    assert calls == [] and result.duration_s < 0.5
    kinds = [e.kind for e in result.events]
    assert "engage" not in kinds and "abort_path" not in kinds
    log = read_log(tmp_path / "a.mcap")
    assert [m["state"] for m in log.messages("/supervisor/state")] == ["preflight", "aborting", "aborted"]
    # during a preflight that waits (a faulted joint): the stop still ends it there
    calls.clear()
    result = run_mission(
        RunTarget(REFERENCE, scenario=SCENARIO, seed=1),
        RunOptions(),
        RunHooks(
            commands=LateAbort(after=20),
            on_supervisor=lambda sup: (spy_engage(calls)(sup), sup.backend.inject("joint_fault", joint=1)),
        ),
    )
    assert result.outcome == "aborted" and result.failure_cause.startswith("operator stop before engagement")
    assert calls == [] and 0.1 < result.duration_s < 1.0


def test_gripper_fault_fails_only_its_leaf(tmp_path) -> None:  # noqa: ANN001
    path = tmp_path / "mission.yaml"
    path.write_text(GRIPPER_MISSION)
    result = run_mission(
        RunTarget(path, scenario=SCENARIO, seed=1),
        RunOptions(log_path=tmp_path / "g.mcap", supervisor=SupervisorOptions(settle_s=0.2)),
        RunHooks(on_supervisor=lambda sup: sup.backend.inject("gripper_fault", start=0.3)),
    )
    assert result.outcome == "succeeded", result.failure_cause  # the fallback ran
    events = [(e.kind, e.level) for e in result.events]
    assert ("gripper_fault", "warning") in events and "abort_path" not in [k for k, _ in events]
    assert any(e.kind == "mission_log" and "going on without it" in e.message for e in result.events)


def test_one_joint_fault_is_one_event_and_runs_end_on_zero_commands(tmp_path) -> None:  # noqa: ANN001
    log_path = tmp_path / "j.mcap"
    result = run_mission(
        RunTarget(REFERENCE, scenario=SCENARIO, seed=1),
        RunOptions(log_path=log_path, supervisor=SupervisorOptions(settle_s=0.5)),
        RunHooks(on_supervisor=lambda sup: sup.backend.inject("joint_fault", start=3.0, joint=2)),
    )
    assert result.outcome == "aborted" and result.failure_cause.startswith("drive_fault (arm)")
    assert sum(1 for e in result.events if e.kind == "drive_fault") == 1
    log = read_log(log_path)
    assert sum(1 for m in log.messages("/events") if m["kind"] == "drive_fault") == 1
    assert not any(log.messages("/vehicle/command")[-1]["body_velocity"])


@pytest.mark.slow
def test_successful_run_logs_the_final_zero_command(reference_run) -> None:  # noqa: ANN001
    code, _, log_path = reference_run
    assert code == 0
    log = read_log(log_path)
    last_state = log.messages("/supervisor/state")[-1]
    assert last_state["state"] == "succeeded"
    after = [m for m in log.messages("/vehicle/command") if m["t"] >= last_state["t"]]
    assert after and not any(after[-1]["body_velocity"]) and not any(log.messages("/arm/command")[-1]["velocity"])


def test_library_warnings_go_to_the_run_log_not_raw_to_stderr(tmp_path, capsys) -> None:  # noqa: ANN001
    noisy = logging.getLogger("canopen.sdo.client")
    said: list = []

    def poll(now: float) -> None:
        if now > 0.5 and not said:
            said.append(now)
            noisy.error("Transfer aborted by client with code 0x05040000")

    log_path = tmp_path / "w.mcap"
    path = tmp_path / "mission.yaml"
    path.write_text(GRIPPER_MISSION)
    result = run_mission(
        RunTarget(path, scenario=SCENARIO, seed=1),
        RunOptions(log_path=log_path, supervisor=SupervisorOptions(settle_s=0.2)),
        RunHooks(pollers=[poll]),
    )
    assert said
    ev = [m for m in read_log(log_path).messages("/events") if m["kind"] == "python_log"]
    assert ev and ev[0]["message"] == "canopen.sdo.client: Transfer aborted by client with code 0x05040000"
    assert ev[0]["fields"] == {"logger": "canopen.sdo.client", "log_level": "ERROR"} and ev[0]["level"] == "warning"
    assert "Transfer aborted" not in capsys.readouterr().err
    assert result.outcome == "succeeded"


def test_preflight_refuses_an_arm_whose_joints_are_not_the_models() -> None:
    def rename(sup) -> None:  # noqa: ANN001
        names = list(sup.devices.arm.joint_names)
        names[1], names[2] = names[2], names[1]
        sup.devices.arm.joint_names = tuple(names)

    result = run_mission(RunTarget(REFERENCE, scenario=SCENARIO, seed=1), RunOptions(), RunHooks(on_supervisor=rename))
    assert result.outcome == "failed"
    assert result.failure_cause.startswith("preflight: arm joints do not match the model: joint names differ")
    assert "#2 is `j3_upper_arm_roll` in the HAL, `j2_shoulder_pitch` in the model (URDF)" in result.failure_cause
