"""A field run (`maris run`, real time) against the protocol peers - CiA 402
drives on udp_multicast CAN, the ArduSub MAVLink peer and a DVL on 127.0.0.1
TCP - replays identically: wall-clock readings, driver health with its
diagnostics (computed between the steps by the drivers' prefetch worker), and
every command at the step it was sent."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

from hal.testing.peers import CAN_GROUP, ROOT, Peer, free_tcp_port
from mission.cli import main
from mission.replay.rawlog import RawLog

pytestmark = [pytest.mark.peer, pytest.mark.slow]

EDS = ROOT / "hal" / "data" / "cia402_minimal.eds"
DRIVE = "counts_per_rad: 1000.0, velocity_units_per_rad_s: 1000.0"
#: The arm joints of the shipped model (kcl/data/r2_uma.urdf), in order.
JOINTS = (
    "j1_shoulder_yaw",
    "j2_shoulder_pitch",
    "j3_upper_arm_roll",
    "j4_elbow_pitch",
    "j5_forearm_roll",
    "j6_wrist_pitch",
    "j7_wrist_roll",
)

MISSION = """\
version: 1
name: field_hold
description: Hold still for a few seconds on the field devices.
rates: {tree_hz: 10, vehicle_hz: 10, arm_hz: 100}
safety:
  max_depth_m: 10.0
  min_altitude_m: 0.5
  max_duration_s: 60
  geofence: {north_m: [-5, 5], east_m: [-5, 5], down_m: [0, 10]}
tree:
  sequence:
    name: Hold
    children:
      - action: {name: Hold still, run: hold, timeout_s: 1.5}
      - wait: {duration_s: 1.0}
abort:
  action: {name: Stop, run: hold, until: converged, timeout_s: 2}
"""


def test_field_run_against_protocol_peers_replays_identically(tmp_path: Path, can_port: int, capsys) -> None:
    drives = Peer("hal.testing.cia402_sim", "--channel", CAN_GROUP, "--port", str(can_port), "--nodes", "1,2,3,4,5,6,7")
    mav_port = free_tcp_port()
    mav = Peer("hal.testing.ardusub_peer", "--url", f"tcpin:127.0.0.1:{mav_port}")
    dvl = Peer("hal.testing.nav_sensor_sim", "dvl-tcp", "--rate", "20", "--velocity", "0.0,0.0,0.0")
    try:
        joints = "\n".join(f"      - {{name: {name}, node_id: {n}, {DRIVE}}}" for n, name in enumerate(JOINTS, start=1))
        cfg = tmp_path / "field.yaml"
        cfg.write_text(f"""\
buses:
  can0: {{interface: udp_multicast, channel: "{CAN_GROUP}", port: {can_port}}}
devices:
  vehicle:
    driver: ardusub
    url: "tcp:127.0.0.1:{mav_port}"
    heartbeat_timeout: 2.0
    dvl: {{transport: tcp, host: 127.0.0.1, port: {int(dvl.ready)}, timeout: 0.3}}
  arm:
    driver: canopen_arm
    bus: can0
    eds: {EDS}
    joints:
{joints}
""")
        mission = tmp_path / "hold.yaml"
        mission.write_text(MISSION)
        log = tmp_path / "field.mcap"
        res = subprocess.run(
            [sys.executable, "-m", "mission.cli", "run", str(mission), "--hal", str(cfg), "--log", str(log), "--quiet"],
            cwd=ROOT,
            capture_output=True,
            text=True,
            timeout=60,
        )
    finally:
        for peer in (drives, mav, dvl):
            peer.stop()
    assert res.returncode == 0, res.stdout + res.stderr
    raw = RawLog(log)
    header = raw.messages("/replay/header")[0]
    assert header["backend"] == "RealBackend" and header["realtime"] and header["joint_names"] == list(JOINTS)
    reads = [r for m in raw.steps() for r in m["reads"]]
    health = [r for r in reads if r["call"] == "arm.health"]
    assert health and "OPERATION ENABLED" in health[-1]["info"]  # the drives' own diagnostics
    served = raw.messages("/run/result")[0]["metrics"]["wall_health_prefetch"]
    assert served["prefetched"] >= 10  # the tree steps read health computed between the steps (and it replays)
    clock = [r["t"] for r in reads if r["call"] == "clock.now"]
    assert len(clock) > 2 * len(raw.steps())  # wall time: every reading differs
    assert main(["log", "replay", str(log)]) == 0
    assert "identical" in capsys.readouterr().out
