"""`maris run` end to end on a mixed HAL config: the ArduSub peer (another process,
127.0.0.1 TCP) as the vehicle, the simulator for the arm, gripper and detector."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

from hal.testing.peers import ROOT, Peer, free_tcp_port

pytestmark = [pytest.mark.peer, pytest.mark.slow]

MISSION = """\
version: 1
name: short_vehicle_check
rates: {tree_hz: 10, vehicle_hz: 10, arm_hz: 100}
safety:
  max_depth_m: 3.0
  min_altitude_m: 0.3
  max_duration_s: 60
  geofence: {north_m: [-3, 3], east_m: [-3, 3], down_m: [0, 3]}
tree:
  sequence:
    name: Check
    children:
      - action: {name: Dive, run: survey, targets: {vehicle_goal: {down_m: 0.6}, tolerance_m: 0.15}, timeout_s: 20}
      - action: {name: Translate, run: survey, targets: {vehicle_goal: {north_m: 0.5}, tolerance_m: 0.15}, timeout_s: 20}
      - action: {name: Turn, run: survey, targets: {vehicle_goal: {yaw_deg: 60}, tolerance_m: 0.3, yaw_tolerance_deg: 6}, timeout_s: 20}
      - action: {name: Surface, run: survey, targets: {vehicle_goal: {down_m: 0.2}, tolerance_m: 0.15}, timeout_s: 20}
abort:
  action: {name: Surface, run: survey, targets: {vehicle_goal: {down_m: 0.2}, tolerance_m: 0.3}, timeout_s: 20}
"""


def run(tmp_path: Path, *peer_args: str) -> tuple[subprocess.CompletedProcess, dict]:
    from hal.testing.peers import peer_report

    port = free_tcp_port()
    peer = Peer("hal.testing.ardusub_peer", "--url", f"tcpin:127.0.0.1:{port}", *peer_args)
    try:
        (tmp_path / "m.yaml").write_text(MISSION)
        (tmp_path / "hal.yaml").write_text(f"""\
devices:
  vehicle: {{driver: ardusub, url: "tcp:127.0.0.1:{port}", max_speed: 0.5, max_yaw_rate: 0.5}}
  arm: {{driver: sim}}
  gripper: {{driver: sim}}
""")
        proc = subprocess.run(
            [
                sys.executable,
                "-m",
                "mission.cli",
                "run",
                str(tmp_path / "m.yaml"),
                "--hal",
                str(tmp_path / "hal.yaml"),
                "--quiet",
                "--log",
                str(tmp_path / "run.mcap"),
            ],
            cwd=ROOT,
            capture_output=True,
            text=True,
            timeout=90,
        )
        return proc, peer_report(peer)
    finally:
        peer.stop()


def test_maris_run_dive_translate_turn_surface(tmp_path: Path) -> None:
    proc, report = run(tmp_path)
    assert proc.returncode == 0, proc.stdout + proc.stderr
    assert "outcome:   succeeded" in proc.stdout
    assert report["armed"] is False and report["setpoints"] > 50  # disarmed at the end, was driven in GUIDED
    assert report["north"] > 0.3 and report["depth"] < 0.4
    assert abs(((report["yaw_deg"] - 60.0) + 180.0) % 360.0 - 180.0) < 8.0


def test_maris_run_fails_preflight_when_arming_is_refused(tmp_path: Path) -> None:
    proc, report = run(tmp_path, "--prearm-fail", "Leak detected")
    assert proc.returncode != 0
    out = proc.stdout + proc.stderr
    assert "preflight: vehicle refused to arm" in out and "PreArm: Leak detected" in out, out
    assert report["armed"] is False and report["setpoints"] == 0
