"""The Reach arm and jaw drivers against the Reach protocol peer in another process
(hal.testing.reach_peer), over a pseudo-terminal (serial) and UDP on 127.0.0.1."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pytest

import sim_backend  # noqa: F401 - registers the simulator (the config's simulated vehicle)
from hal.check import check_hal
from hal.config import load_hal_config
from hal.drivers.reach_arm import ReachArm
from hal.drivers.reach_jaw import ReachJaw
from hal.drivers.realtime import MonotonicClock
from hal.interfaces import EngageRefused, GripperMotion, HealthState
from hal.testing.peers import Peer, peer_report, wait_until
from kcl.model import DATA_DIR, UvmsModel

pytestmark = pytest.mark.peer

HOST = Path(__file__).with_name("reach_host.py")
ALPHA_JOINTS = """\
      - {name: a_base, device_id: 5, max_velocity: 0.4}
      - {name: a_shoulder, device_id: 4, max_velocity: 0.4}
      - {name: a_elbow, device_id: 3, max_velocity: 0.4}
      - {name: a_wrist, device_id: 2, max_velocity: 0.4}"""


def write_config(tmp: Path, link: str, *, extra: str = "", jaw: bool = True, joints: str = ALPHA_JOINTS) -> Path:
    cfg = tmp / "hal.yaml"
    cfg.write_text(
        f"""\
devices:
  vehicle: {{driver: sim}}
  arm:
    driver: reach_arm
{link}
    stale_timeout: 0.3
{extra}
    joints:
{joints}
"""
        + (
            "  gripper: {driver: reach_jaw, link: arm, stale_timeout: 0.3, preshapes: {parallel: 10.0}}\n"
            if jaw
            else ""
        )
    )
    return cfg


def serial_link(peer: Peer) -> str:
    return f"    transport: serial\n    device: {peer.ready}"


def udp_link(peer: Peer) -> str:
    return f"    transport: udp\n    host: 127.0.0.1\n    port: {peer.ready}"


@pytest.fixture
def alpha_peer() -> Iterator[Peer]:
    peer = Peer("hal.testing.reach_peer", "--transport", "serial", "--arm", "alpha5")
    yield peer
    peer.stop()


@pytest.fixture
def clock() -> MonotonicClock:
    return MonotonicClock()


def make_arm(cfg: Path, clock: MonotonicClock) -> tuple[ReachArm, ReachJaw | None]:
    config = load_hal_config(cfg)
    arm = ReachArm(config.devices["arm"].params, clock.now)
    jaw = ReachJaw(config.devices["gripper"].params, clock.now) if "gripper" in config.devices else None
    return arm, jaw


@pytest.fixture
def alpha(alpha_peer: Peer, tmp_path: Path, clock: MonotonicClock) -> Iterator[tuple[ReachArm, ReachJaw, Peer]]:
    arm, jaw = make_arm(write_config(tmp_path, serial_link(alpha_peer)), clock)
    assert jaw is not None
    arm.connect()
    jaw.connect()
    assert wait_until(lambda: arm.health().state == HealthState.OK, 3.0), arm.health()
    # the jaw refuses motion until its first reading (as a run's preflight waits for it)
    assert wait_until(lambda: jaw.health().state == HealthState.OK, 5.0), jaw.health()
    yield arm, jaw, alpha_peer
    jaw.disconnect()
    arm.disconnect()


def command_until(arm: ReachArm, qdot: float, predicate: object, timeout: float) -> bool:
    """Command ``qdot`` on every joint at 100 Hz (as the KCL does; an enabled arm left without
    commands is stopped by the guardian) until ``predicate()`` holds or ``timeout`` s pass."""
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        arm.command_joint_velocity(np.full(len(arm.joint_names), qdot))
        if predicate():  # type: ignore[operator]
            return True
        time.sleep(0.01)
    return False


def count_packets(arm: ReachArm, seconds: float) -> int:
    n0 = arm.link.decoder.packets
    time.sleep(seconds)
    return arm.link.decoder.packets - n0


def test_feedback_streams_at_the_configured_rate_and_commands_go_at_the_kcl_rate(
    alpha: tuple[ReachArm, ReachJaw, Peer],
) -> None:
    arm, _jaw, peer = alpha
    # 5 devices x 3 streamed packets at 20 Hz, plus the status answers (2 per device every 0.5 s)
    per_s = count_packets(arm, 2.0) / 2.0
    assert 0.85 * 300 <= per_s <= 1.15 * 320, per_s
    info = arm.health().info
    assert info["rejected"] == {"cobs": 0, "crc": 0, "length": 0, "overflow": 0} and info["guardian"] == "running"
    arm.enable()
    p0 = arm.joint_state().position
    t_end = time.monotonic() + 1.5
    steps = 0
    while time.monotonic() < t_end:  # the KCL arm step at 100 Hz
        arm.command_joint_velocity(np.array([0.2, 0.1, -0.1, 0.9]))  # the wrist's 0.9 is clipped to 0.4
        steps += 1
        time.sleep(0.01)
    rep = peer_report(peer)
    dev = rep["devices"]
    assert dev["2"]["demand_velocity"] == pytest.approx(0.4, abs=1e-6)
    assert dev["5"]["mode"] == 0x03 and dev["5"]["demand_velocity"] == pytest.approx(0.2, abs=1e-6)
    assert rep["velocity_packets_last_s"] >= 0.9 * 4 * steps / 1.5  # every step's four demands arrived
    js = arm.joint_state()
    assert js.fault is None and js.position[0] > p0[0] + 0.15 and js.position[2] < p0[2] - 0.08
    assert np.allclose(js.velocity, [0.2, 0.1, -0.1, 0.4], atol=0.02)
    assert arm._clock() - js.t < 0.2  # noqa: SLF001 - the stamp is the reading's arrival


def test_modes_are_confirmed_and_disable_leaves_standby(alpha: tuple[ReachArm, ReachJaw, Peer]) -> None:
    arm, _jaw, peer = alpha
    arm.enable()
    assert [p["mode"] for p in arm.health().info["parts"]] == ["VELOCITY"] * 4
    arm.command_joint_velocity(np.full(4, 0.2))
    time.sleep(0.2)
    arm.disable()
    rep = peer_report(peer)
    assert all(d["mode"] == 0 and d["demand_velocity"] == 0.0 for d in rep["devices"].values())
    arm.command_joint_velocity(np.full(4, 0.2))  # ignored: not enabled
    time.sleep(0.2)
    assert peer_report(peer)["devices"]["5"]["demand_velocity"] == 0.0


def test_killed_peer_is_detected_within_the_watchdog(alpha: tuple[ReachArm, ReachJaw, Peer]) -> None:
    arm, jaw, peer = alpha
    arm.enable()
    arm.command_joint_velocity(np.full(4, 0.1))
    peer.proc.kill()  # SIGKILL: the pty master closes
    t0 = time.monotonic()
    assert command_until(arm, 0.1, lambda: arm.health().state == HealthState.FAULT, 2.0)
    assert time.monotonic() - t0 < arm.stale_timeout + 0.3
    h = arm.health()
    assert "stale readings" in h.detail and "lost" in h.detail, h.detail
    assert arm.joint_state().fault
    assert wait_until(lambda: not arm._enabled, 0.5)  # noqa: SLF001 - tripped to the safe state
    assert wait_until(lambda: jaw.health().state == HealthState.FAULT, 1.0)
    with pytest.raises(EngageRefused, match="stale"):
        arm.enable()


def test_stalled_peer_is_detected_within_the_watchdog(alpha: tuple[ReachArm, ReachJaw, Peer]) -> None:
    arm, _jaw, peer = alpha
    arm.enable()
    peer.send(cmd="stall")
    t0 = time.monotonic()
    assert command_until(arm, 0.0, lambda: arm.health().state == HealthState.FAULT, 2.0)
    assert time.monotonic() - t0 < arm.stale_timeout + 0.3
    assert "stale readings" in arm.health().detail and "link open" in arm.health().detail
    peer.send(cmd="resume")
    assert wait_until(lambda: arm._problem(arm._clock()) is None, 2.0)  # noqa: SLF001
    arm.enable()  # the cause is gone: enabling clears the latched fault
    assert arm.health().state == HealthState.OK


def test_crc_and_cobs_errors_are_counted_and_skipped(alpha: tuple[ReachArm, ReachJaw, Peer]) -> None:
    arm, _jaw, peer = alpha
    peer.send(cmd="corrupt", kind="crc", count=4)
    peer.send(cmd="corrupt", kind="cobs", count=3)
    assert wait_until(lambda: sum(arm.link.decoder.errors.values()) >= 7, 2.0), arm.link.decoder.errors
    errors = arm.health().info["rejected"]
    assert errors["crc"] == 4 and errors["cobs"] + errors["length"] == 3, errors
    assert arm.health().state == HealthState.OK  # later packets decode: readings stay fresh
    assert arm.joint_state().fault is None


def test_a_joint_fault_stops_the_arm(alpha: tuple[ReachArm, ReachJaw, Peer]) -> None:
    arm, _jaw, peer = alpha
    arm.enable()
    peer.send(cmd="joint_fault", device=3, flags=0x14)
    assert command_until(arm, 0.2, lambda: arm.health().state == HealthState.FAULT, 2.0)
    detail = arm.health().detail
    assert "a_elbow (device 0x03): hardware status flags 0x00000014 (bits 2, 4)" in detail, detail
    assert "a_elbow" in (arm.joint_state().fault or "")
    assert wait_until(lambda: peer_report(peer)["devices"]["5"]["mode"] == 0, 1.0)  # the others in STANDBY
    with pytest.raises(EngageRefused, match="status flags"):
        arm.enable()
    peer.send(cmd="clear_fault", device=3)
    assert wait_until(lambda: arm._problem(arm._clock()) is None, 2.0)  # noqa: SLF001
    assert arm.reset_faults() and arm.health().state == HealthState.OK


def test_jaw_grasps_on_current_and_tells_nothing_from_an_object(alpha: tuple[ReachArm, ReachJaw, Peer]) -> None:
    _arm, jaw, peer = alpha
    peer.send(cmd="object", width_mm=6.0)
    jaw.close(0.4)
    assert wait_until(lambda: jaw.state().motion == GripperMotion.HOLDING, 5.0), jaw.state()
    st = jaw.state()
    assert st.positions[0] == pytest.approx(0.006, abs=3e-4) and st.currents[0] >= 0.38  # squeezing: confirmed
    assert wait_until(lambda: peer_report(peer)["devices"]["1"]["mode"] == 0x04, 1.0)  # held by a current demand
    jaw.open()
    assert wait_until(lambda: jaw.state().motion == GripperMotion.IDLE, 5.0)
    assert jaw.state().positions[0] == pytest.approx(0.012, abs=5e-4)
    peer.send(cmd="object", width_mm=None)
    jaw.close(0.4)
    assert wait_until(lambda: jaw.state().motion == GripperMotion.STOPPED, 8.0), jaw.state()
    assert jaw.state().positions[0] < 0.001  # closed on nothing
    jaw.preshape("parallel")
    assert wait_until(lambda: jaw.state().motion == GripperMotion.IDLE, 5.0)
    assert jaw.state().positions[0] == pytest.approx(0.010, abs=5e-4)


def test_bravo_over_udp_with_urdf_limits(tmp_path: Path, clock: MonotonicClock) -> None:
    peer = Peer("hal.testing.reach_peer", "--transport", "udp", "--arm", "bravo7")
    try:
        urdf = tmp_path / "b.urdf"
        names = ["g", "f", "e", "d", "c", "b"]
        ranges = {"g": 6.3, "f": 3.2, "e": 3.2, "d": 6.2, "c": 3.2, "b": 6.2}
        urdf.write_text(
            "<robot name='b'>"
            + "".join(
                f"<joint name='{n}' type='revolute'><limit lower='0' upper='{ranges[n] + (0.3 if n == 'e' else 0)}'"
                " velocity='0.5' effort='1'/></joint>"
                for n in names
            )
            + "</robot>"
        )
        joints = "\n".join(f"      - {{name: {n}, device_id: {7 - i}}}" for i, n in enumerate(names))
        cfg = write_config(tmp_path, udp_link(peer), extra=f"    urdf: {urdf}", jaw=False, joints=joints)
        arm, _ = make_arm(cfg, clock)
        arm.connect()
        try:
            assert wait_until(lambda: arm.health().state == HealthState.FAULT and arm._limit_problems, 3.0)  # noqa: SLF001
            assert "joint e: the URDF's range 0.000..3.500 rad exceeds the device's position limits" in (
                arm.health().detail
            )
            with pytest.raises(EngageRefused, match="exceeds"):
                arm.enable()
            urdf.write_text(urdf.read_text().replace("upper='3.5'", "upper='3.2'"))
            assert wait_until(lambda: arm.health().state == HealthState.OK, 3.0), arm.health()
            arm.enable()
            for _ in range(50):
                arm.command_joint_velocity(np.full(6, 0.1))
                time.sleep(0.01)
            assert peer_report(peer)["devices"]["7"]["demand_velocity"] == pytest.approx(0.1, abs=1e-6)
        finally:
            arm.disconnect()
        assert all(d["mode"] == 0 for d in peer_report(peer)["devices"].values() if d != "1")
    finally:
        peer.stop()


# ---------------------------------------------------------------------- the host process dies


def run_host(cfg: Path) -> subprocess.Popen[str]:
    proc = subprocess.Popen(
        [sys.executable, str(HOST), str(cfg), "--velocity", "0.3"], stdout=subprocess.PIPE, text=True
    )
    assert proc.stdout is not None
    line = proc.stdout.readline()
    assert line.strip() == "MOVING", line
    return proc


def moving(peer: Peer) -> list[float]:
    return [d["velocity"] for k, d in peer_report(peer)["devices"].items() if k != "1"]


@pytest.mark.slow
@pytest.mark.parametrize("transport", ["serial", "udp"])
def test_host_killed_mid_motion_the_guardian_stops_the_arm(tmp_path: Path, transport: str) -> None:
    peer = Peer("hal.testing.reach_peer", "--transport", transport, "--arm", "alpha5")
    try:
        link = serial_link(peer) if transport == "serial" else udp_link(peer)
        host = run_host(write_config(tmp_path, link, jaw=False))
        assert wait_until(lambda: min(moving(peer)) > 0.25, 3.0), moving(peer)
        host.send_signal(signal.SIGKILL)
        host.wait(timeout=5)
        t0 = time.monotonic()
        assert wait_until(lambda: max(abs(v) for v in moving(peer)) < 1e-6, 2.0), moving(peer)
        stopped_after = time.monotonic() - t0
        rep = peer_report(peer)
        assert all(d["mode"] == 0 and d["demand_velocity"] == 0.0 for d in rep["devices"].values())
        print(f"{transport}: arm stopped {stopped_after:.3f} s after SIGKILL of the host")
    finally:
        peer.stop()


@pytest.mark.slow
def test_host_killed_without_guardian_the_arm_keeps_moving(tmp_path: Path) -> None:
    """What the arm itself does (the protocol has no timeout on a velocity demand)."""
    peer = Peer("hal.testing.reach_peer", "--transport", "udp", "--arm", "alpha5")
    try:
        host = run_host(write_config(tmp_path, udp_link(peer), extra="    guardian: false", jaw=False))
        assert wait_until(lambda: min(moving(peer)) > 0.25, 3.0)
        host.send_signal(signal.SIGKILL)
        host.wait(timeout=5)
        time.sleep(1.0)
        rep = peer_report(peer)["devices"]
        assert all(rep[k]["velocity"] > 0.25 and rep[k]["mode"] == 0x03 for k in ("2", "3", "4", "5")), rep
    finally:
        peer.stop()


@pytest.mark.slow
@pytest.mark.parametrize("sig", [signal.SIGTERM, signal.SIGINT])
def test_host_terminated_or_interrupted_stops_the_arm_itself(tmp_path: Path, sig: signal.Signals) -> None:
    """Without the guardian: SIGTERM (no handler of the application's) reaches the driver's
    own handler; SIGINT raises KeyboardInterrupt and the interpreter's exit (atexit) stops it."""
    peer = Peer("hal.testing.reach_peer", "--transport", "udp", "--arm", "alpha5")
    try:
        host = run_host(write_config(tmp_path, udp_link(peer), extra="    guardian: false", jaw=False))
        assert wait_until(lambda: min(moving(peer)) > 0.25, 3.0)
        host.send_signal(sig)
        assert host.wait(timeout=15) in (-sig, 1)
        assert wait_until(lambda: max(abs(v) for v in moving(peer)) < 1e-6, 2.0), moving(peer)
    finally:
        peer.stop()


@pytest.mark.slow
def test_stopped_host_is_stopped_by_the_guardian_and_then_faults(tmp_path: Path) -> None:
    """SIGSTOP (Ctrl-Z, a hung loop): no command for guard_timeout -> the guardian stops the arm."""
    peer = Peer("hal.testing.reach_peer", "--transport", "udp", "--arm", "alpha5")
    try:
        host = run_host(write_config(tmp_path, udp_link(peer), jaw=False))
        assert wait_until(lambda: min(moving(peer)) > 0.25, 3.0)
        os.kill(host.pid, signal.SIGSTOP)
        try:
            assert wait_until(lambda: max(abs(v) for v in moving(peer)) < 1e-6, 2.0), moving(peer)
        finally:
            os.kill(host.pid, signal.SIGCONT)
        host.kill()
        host.wait(timeout=5)
    finally:
        peer.stop()


def test_hal_check_rows_with_the_shipped_models(alpha_peer: Peer, tmp_path: Path) -> None:
    """`maris hal check`: one row per role, the arm's parts one per joint, the device's
    limits within the shipped Alpha 5 model's (kcl/data/bluerov2_heavy_alpha5.urdf)."""

    urdf = DATA_DIR / "bluerov2_heavy_alpha5.urdf"
    joints = "\n".join(
        f"      - {{name: {n}, device_id: {5 - i}}}" for i, n in enumerate(UvmsModel.load(urdf).joint_names)
    )
    cfg = write_config(tmp_path, serial_link(alpha_peer), extra=f"    urdf: {urdf}", joints=joints)
    report = check_hal(load_hal_config(cfg), wait=4.0, model_joints=list(UvmsModel.load(urdf).joint_names))
    rows = {r.role: r for r in report.rows}
    assert rows["arm"].state == "ok" and rows["gripper"].state == "ok", (rows["arm"].detail, rows["gripper"].detail)
    assert [p["name"] for p in rows["arm"].parts] == [
        "alpha_e_base",
        "alpha_d_shoulder",
        "alpha_c_elbow",
        "alpha_b_wrist",
    ]
    assert rows["arm"].parts[0]["limits"]["position_limits"] == [0.0, 6.3]
    assert rows["arm"].info["guardian"] == "running" and rows["arm"].info["link_state"] == "open"
    assert rows["gripper"].parts[0]["name"] == "jaw" and rows["gripper"].parts[0]["opening_mm"] == 12.0
    assert wait_until(lambda: all(d["mode"] == 0 for d in peer_report(alpha_peer)["devices"].values()), 2.0)
