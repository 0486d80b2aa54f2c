"""ArduSub vehicle driver against the firmware-faithful peer (hal.testing.ardusub_peer)
in another process, on 127.0.0.1; one test per firmware behaviour of issue 12."""

from __future__ import annotations

import math
import time
from pathlib import Path

import numpy as np
import pytest
from pymavlink import mavutil

from hal.drivers.realtime import MonotonicClock
from hal.drivers.vehicle_ardusub import ArdusubVehicle
from hal.interfaces import EngageRefused, HealthState
from hal.testing.peers import Peer, free_tcp_port, peer_report, wait_until

MAV = mavutil.mavlink


def _params(tmp_path: Path, extra: str = "") -> dict:
    from hal.config import DRIVER_SCHEMAS, _check_mapping  # noqa: PLC0415 - validate the vehicle entry alone
    from maris_common.yamlsrc import load_yaml

    cfg = tmp_path / "hal.yaml"
    cfg.write_text(f'devices:\n  vehicle: {{driver: ardusub, url: "tcp:127.0.0.1:1", heartbeat_timeout: 2.0{extra}}}\n')
    src = load_yaml(cfg)
    issues: list = []
    raw = {k: v for k, v in src.data["devices"]["vehicle"].items() if k != "driver"}
    params = _check_mapping(src, ("devices", "vehicle"), raw, DRIVER_SCHEMAS["ardusub"][1], cfg.parent, issues)
    assert not issues, issues
    return params


def start(tmp_path: Path, *peer_args: str, extra: str = ""):  # noqa: ANN201
    port = free_tcp_port()
    peer = Peer("hal.testing.ardusub_peer", "--url", f"tcpin:127.0.0.1:{port}", *peer_args)
    params = _params(tmp_path, extra)
    params["url"] = f"tcp:127.0.0.1:{port}"
    vehicle = ArdusubVehicle(params, MonotonicClock().now)
    vehicle.connect()
    return vehicle, peer


@pytest.fixture
def rig(tmp_path: Path, request):  # noqa: ANN001, ANN201
    args = getattr(request, "param", ())
    vehicle, peer = start(tmp_path, *args)
    yield vehicle, peer
    vehicle.disconnect()
    peer.stop()


def ready(vehicle: ArdusubVehicle, timeout: float = 8.0) -> None:
    assert wait_until(lambda: vehicle.health().state.usable, timeout), vehicle.health()


def drive(vehicle: ArdusubVehicle, v: list[float], seconds: float) -> None:
    """Stream a body velocity reference like a 10 Hz control loop."""
    end = time.monotonic() + seconds
    while time.monotonic() < end:
        vehicle.command_body_velocity(np.array(v, dtype=float))
        time.sleep(0.05)


@pytest.mark.peer
@pytest.mark.slow
def test_streams_are_off_until_requested() -> None:
    """A bare ground station hears only HEARTBEAT (and origin/home) until it asks."""
    port = free_tcp_port()
    peer = Peer("hal.testing.ardusub_peer", "--url", f"tcpin:127.0.0.1:{port}")
    conn = mavutil.mavlink_connection(f"tcp:127.0.0.1:{port}", source_system=255, source_component=190)
    try:
        seen: set[str] = set()
        end = time.monotonic() + 2.0
        while time.monotonic() < end:
            conn.mav.heartbeat_send(MAV.MAV_TYPE_GCS, MAV.MAV_AUTOPILOT_INVALID, 0, 0, 0)
            m = conn.recv_match(blocking=True, timeout=0.2)
            if m is not None:
                seen.add(m.get_type())
        assert "HEARTBEAT" in seen and not seen & {"ATTITUDE", "GLOBAL_POSITION_INT", "SCALED_PRESSURE2", "SYS_STATUS"}
        conn.mav.command_long_send(1, 1, MAV.MAV_CMD_SET_MESSAGE_INTERVAL, 0, 30, 50000, 0, 0, 0, 0, 0)
        assert conn.recv_match(type="ATTITUDE", blocking=True, timeout=3.0) is not None
    finally:
        conn.close()
        peer.stop()


@pytest.mark.peer
@pytest.mark.slow
def test_requested_streams_health_version_and_gcs_heartbeat_first(rig) -> None:  # noqa: ANN001
    vehicle, peer = rig
    ready(vehicle)
    info = vehicle.health().info["ardusub"]
    assert info["version"].startswith("ArduSub 4.0.2") and info["yaw_path"] == "condition_yaw"
    assert info["mode"] == "MANUAL" and info["armed"] is False and "pos_horiz_rel" in info["ekf_flags"]
    assert wait_until(lambda: (vehicle.health().info["ardusub"]["rates_hz"]["ATTITUDE"] or 0) > 10, 4.0)
    nav = vehicle.navigation()
    assert nav.depth == pytest.approx(0.0, abs=0.02) and np.allclose(nav.position[:2], 0.0, atol=0.05)
    report = peer_report(peer)
    assert report["first_msg"] == "HEARTBEAT" and report["gcs_heartbeat_sysids"] == [255]
    assert report["setpoints"] == 0  # nothing moves the vehicle before it is armed in GUIDED


@pytest.mark.peer
@pytest.mark.slow
@pytest.mark.parametrize("profile", ["4.0", "4.5"])
def test_guided_refused_without_position(tmp_path: Path, profile: str) -> None:
    vehicle, peer = start(tmp_path, "--position", "none", "--profile", profile)
    try:
        assert wait_until(lambda: "position unknown" in vehicle.health().detail, 8.0), vehicle.health()
        assert np.isnan(vehicle.navigation().position[0])  # unknown, not (0, 0, 0)
        with pytest.raises(EngageRefused) as exc:
            vehicle.arm()
        msg = str(exc.value)
        assert "refused mode GUIDED (COMMAND_ACK UNSUPPORTED)" in msg and "position estimate" in msg
        if profile == "4.5":
            assert "Mode change failed: Guided requires position" in msg
        report = peer_report(peer)
        assert report["armed"] is False and report["mode"] == 19 and report["setpoints"] == 0
    finally:
        vehicle.disconnect()
        peer.stop()


@pytest.mark.peer
@pytest.mark.slow
@pytest.mark.parametrize("rig", [("--prearm-fail", "Compass not calibrated")], indirect=True)
def test_prearm_refusal_names_the_statustext(rig) -> None:  # noqa: ANN001
    vehicle, peer = rig
    ready(vehicle)
    with pytest.raises(EngageRefused, match=r'refused arming \(COMMAND_ACK FAILED\): "PreArm: Compass not calibrated"'):
        vehicle.arm()
    assert peer_report(peer)["armed"] is False


@pytest.mark.peer
@pytest.mark.slow
def test_world_frame_does_not_move_when_home_moves_at_arming(rig) -> None:  # noqa: ANN001
    vehicle, peer = rig
    ready(vehicle)
    vehicle.arm()
    drive(vehicle, [0.4, 0.0, 0.0, 0.0, 0.0, 0.0], 2.0)
    vehicle.disarm()
    vehicle.arm()  # ArduSub moves HOME to the vehicle here (LOCAL_POSITION_NED in 4.0 jumps to 0)
    time.sleep(0.5)
    report = peer_report(peer)
    assert report["home"][0] > 0.3  # HOME did move
    nav = vehicle.navigation()
    assert nav.position[0] == pytest.approx(report["north"], abs=0.1)
    assert nav.position[1] == pytest.approx(report["east"], abs=0.1)
    vehicle.disarm()


@pytest.mark.peer
@pytest.mark.slow
@pytest.mark.parametrize("profile,path", [("4.0", "condition_yaw"), ("4.5", "setpoint_yaw_rate")])
def test_heading_control_works_on_each_version(tmp_path: Path, profile: str, path: str) -> None:
    vehicle, peer = start(tmp_path, "--profile", profile)
    try:
        ready(vehicle)
        vehicle.arm()
        assert vehicle.link.yaw_path == path
        yaw0 = float(vehicle.navigation().attitude[2])
        drive(vehicle, [0.0, 0.0, 0.0, 0.0, 0.0, 0.3], 2.0)
        turned = math.remainder(float(vehicle.navigation().attitude[2]) - yaw0, 2 * math.pi)
        assert turned > 0.3, turned
        drive(vehicle, [0.0] * 6, 2.0)  # zero yaw rate: the heading settles and holds (no auto-yaw swing)
        y1 = float(vehicle.navigation().attitude[2])
        drive(vehicle, [0.0] * 6, 1.0)
        assert abs(math.remainder(float(vehicle.navigation().attitude[2]) - y1, 2 * math.pi)) < 0.1
        vehicle.disarm()
    finally:
        vehicle.disconnect()
        peer.stop()


@pytest.mark.peer
@pytest.mark.slow
@pytest.mark.parametrize("profile", ["4.0", "4.5"])
def test_setpoint_yaw_rate_is_ignored_by_4_0_only(profile: str) -> None:
    """Raw ground station: pin a heading with CONDITION_YAW, then stream yaw-rate setpoints."""
    port = free_tcp_port()
    peer = Peer("hal.testing.ardusub_peer", "--url", f"tcpin:127.0.0.1:{port}", "--profile", profile, "--sitl")
    conn = mavutil.mavlink_connection(f"tcp:127.0.0.1:{port}", source_system=255, source_component=190)

    def cmd(c: int, *p: float) -> None:
        conn.mav.command_long_send(1, 1, c, 0, *(list(p) + [0.0] * (7 - len(p))))
        ack = conn.recv_match(type="COMMAND_ACK", blocking=True, timeout=2.0)
        assert ack is not None and ack.result == 0, ack

    try:
        conn.mav.heartbeat_send(MAV.MAV_TYPE_GCS, MAV.MAV_AUTOPILOT_INVALID, 0, 0, 0)
        assert conn.recv_match(type="HEARTBEAT", blocking=True, timeout=3.0) is not None
        cmd(MAV.MAV_CMD_DO_SET_MODE, 1, 4)
        cmd(MAV.MAV_CMD_COMPONENT_ARM_DISARM, 1)
        cmd(MAV.MAV_CMD_SET_MESSAGE_INTERVAL, 30, 50000)
        cmd(MAV.MAV_CMD_CONDITION_YAW, 100.0, 0, 1, 0)
        end = time.monotonic() + 3.0  # let the heading reach 100 deg
        while time.monotonic() < end:
            conn.mav.heartbeat_send(MAV.MAV_TYPE_GCS, MAV.MAV_AUTOPILOT_INVALID, 0, 0, 0)
            time.sleep(0.2)
        assert abs(peer_report(peer)["yaw_deg"] - 100.0) < 5.0
        end = time.monotonic() + 2.0
        while time.monotonic() < end:
            conn.mav.heartbeat_send(MAV.MAV_TYPE_GCS, MAV.MAV_AUTOPILOT_INVALID, 0, 0, 0)
            conn.mav.set_position_target_local_ned_send(
                0, 1, 1, MAV.MAV_FRAME_BODY_OFFSET_NED, 0x05C7, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0.5
            )
            time.sleep(0.1)
            while conn.recv_match(blocking=False) is not None:
                pass
        report = peer_report(peer)
        yaw = report["yaw_deg"]
        if profile == "4.0":
            assert abs(yaw - 100.0) < 5.0, yaw  # the rate was ignored: heading stays pinned
        else:
            assert abs(math.remainder(yaw - 100.0, 360.0)) > 20.0, yaw  # the rate turned the vehicle
    finally:
        conn.close()
        peer.stop()


@pytest.mark.peer
@pytest.mark.slow
def test_manual_control_is_thrust_with_a_measured_scale(tmp_path: Path) -> None:
    # peer: full thrust 1.5 m/s surge, JS_GAIN 0.5 -> 0.75 m/s at full stick, measured as such
    extra = (
        ", arm_mode: MANUAL, command: manual_control, "
        "manual_full_stick: {surge_mps: 0.75, sway_mps: 0.6, heave_mps: 0.5, yaw_rad_s: 0.75}"
    )
    vehicle, peer = start(tmp_path, extra=extra)
    try:
        ready(vehicle)
        vehicle.arm()
        drive(vehicle, [0.3, 0.0, 0.0, 0.0, 0.0, 0.0], 3.5)
        assert vehicle.navigation().body_velocity[0] == pytest.approx(0.3, abs=0.04)
        vehicle.disarm()
    finally:
        vehicle.disconnect()
        peer.stop()


def test_manual_control_needs_the_full_stick_scale(tmp_path: Path) -> None:
    from hal.config import load_hal_config
    from maris_common.yamlsrc import ConfigError

    cfg = tmp_path / "hal.yaml"
    cfg.write_text(
        'devices:\n  vehicle: {driver: ardusub, url: "udpin:127.0.0.1:14550", arm_mode: MANUAL, '
        "command: manual_control}\n  arm: {driver: sim}\n"
    )
    with pytest.raises(ConfigError, match="sticks are thrust, not velocity"):
        load_hal_config(cfg)


def test_a_heartbeat_limit_below_two_periods_is_refused(tmp_path: Path) -> None:
    from hal.config import load_hal_config
    from maris_common.yamlsrc import ConfigError

    cfg = tmp_path / "hal.yaml"
    cfg.write_text(
        'devices:\n  vehicle: {driver: ardusub, url: "udpin:127.0.0.1:14550", heartbeat_timeout: 1.0}\n'
        "  arm: {driver: sim}\n"
    )
    with pytest.raises(
        ConfigError, match=r"heartbeat_timeout: must be at least 2 s \(ArduSub sends HEARTBEAT at 1 Hz\)"
    ):
        load_hal_config(cfg)


@pytest.mark.peer
@pytest.mark.slow
def test_autopilot_restart_reconnects_with_back_off(rig) -> None:  # noqa: ANN001
    vehicle, peer = rig
    ready(vehicle)
    attempts0 = vehicle.link.open_attempts
    peer.send(cmd="restart", down_s=2.0)
    assert wait_until(lambda: "heartbeat lost" in vehicle.health().detail, 4.0), vehicle.health()
    assert wait_until(lambda: vehicle.health().state.usable, 12.0), vehicle.health()
    assert vehicle.link.open_attempts - attempts0 <= 5  # back-off, not a busy loop
    assert wait_until(lambda: (vehicle.health().info["ardusub"]["rates_hz"]["ATTITUDE"] or 0) > 10, 4.0)  # re-requested
    assert vehicle.health().state != HealthState.MISSING


def test_no_autopilot_names_the_url(tmp_path: Path) -> None:
    params = _params(tmp_path)
    params["url"] = f"tcp:127.0.0.1:{free_tcp_port()}"
    vehicle = ArdusubVehicle(params, MonotonicClock().now)
    vehicle.connect()
    try:
        assert wait_until(lambda: "Connection refused" in vehicle.health().detail, 3.0)
        h = vehicle.health()
        assert h.state == HealthState.MISSING and params["url"] in h.detail
        assert np.isnan(vehicle.navigation().t)
    finally:
        vehicle.disconnect()
