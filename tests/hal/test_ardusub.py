"""ArduSub vehicle driver against an ArduSub-like pymavlink peer process on 127.0.0.1 UDP."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from hal.drivers.realtime import MonotonicClock
from hal.drivers.vehicle_ardusub import ArdusubVehicle
from hal.interfaces import HealthState
from hal.testing.peers import Peer, free_udp_port, wait_until


@pytest.fixture(params=["udp", "tcp"])
def link(request, tmp_path: Path):  # noqa: ANN001, ANN201
    port = free_udp_port()
    peer_url, our_url = {"udp": (f"udpout:127.0.0.1:{port}", f"udpin:127.0.0.1:{port}"),
                         "tcp": (f"tcpin:127.0.0.1:{port}", f"tcp:127.0.0.1:{port}")}[request.param]
    peer = Peer("hal.testing.ardusub_peer", "--url", peer_url, "--heartbeat-rate", "5")
    cfg = tmp_path / "hal.yaml"
    cfg.write_text(f'devices:\n  vehicle: {{driver: ardusub, url: "{our_url}", heartbeat_timeout: 0.6, telemetry_timeout: 0.5}}\n')
    params = _params(cfg)
    vehicle = ArdusubVehicle(params, MonotonicClock().now)
    vehicle.connect()
    yield vehicle, peer
    vehicle.disconnect()
    peer.stop()


def _params(cfg: Path) -> dict:
    from hal.config import DRIVER_SCHEMAS, _check_mapping  # noqa: PLC0415 - validate the vehicle entry alone
    from maris_common.yamlsrc import load_yaml

    src = load_yaml(cfg)
    issues: list = []
    raw = {k: v for k, v in src.data["devices"]["vehicle"].items() if k != "driver"}
    params = _check_mapping(src, ("devices", "vehicle"), raw, DRIVER_SCHEMAS["ardusub"][1], cfg.parent, issues)
    assert not issues, issues
    return params


def test_telemetry_mode_arm_and_velocity(link) -> None:  # noqa: ANN001
    vehicle, _ = link
    assert wait_until(lambda: vehicle.health().state == HealthState.OK, 5.0), vehicle.health()
    h = vehicle.health()
    assert h.info["ardusub"]["mode"] == "MANUAL" and h.info["ardusub"]["armed"] is False
    assert wait_until(lambda: vehicle.health().info["ardusub"]["rates_hz"].get("ATTITUDE", 0) > 5, 2.0)
    assert wait_until(lambda: vehicle.navigation().altitude is not None, 2.0)  # rangefinder at 5 Hz
    nav = vehicle.navigation()
    assert nav.depth == pytest.approx(2.0, abs=1e-3) and nav.altitude == pytest.approx(10.0, abs=0.02)
    assert nav.body_velocity is not None and np.allclose(nav.body_velocity, 0.0)
    vehicle.arm()
    assert wait_until(lambda: vehicle.armed, 3.0)
    assert vehicle.health().info["ardusub"]["mode"] == "GUIDED"
    x0 = vehicle.navigation().position[0]
    for _ in range(100):  # commands streamed by the driver; keep them fresh like a control loop would
        vehicle.command_body_velocity(np.array([0.4, 0.0, 0.1, 0.3, 0.3, 0.0]))
        if vehicle.navigation().position[0] > x0 + 0.1:
            break
        wait_until(lambda: False, 0.02)
    nav = vehicle.navigation()
    assert nav.position[0] > x0 + 0.1 and nav.depth > 2.0
    assert nav.body_velocity[0] == pytest.approx(0.4, abs=1e-3)
    assert wait_until(lambda: np.allclose(vehicle.navigation().body_velocity[:3], 0.0), 2.0)  # stale setpoint -> zero
    vehicle.disarm()
    assert wait_until(lambda: not vehicle.armed, 3.0)


def test_lost_mavlink_heartbeat_is_a_fault_and_recovers(link) -> None:  # noqa: ANN001
    vehicle, peer = link
    assert wait_until(lambda: vehicle.health().state == HealthState.OK, 5.0)
    peer.send(cmd="silence")
    assert wait_until(lambda: vehicle.health().state == HealthState.FAULT, 3.0)
    assert "no fresh ATTITUDE" in vehicle.health().detail  # telemetry goes stale first
    assert wait_until(lambda: "MAVLink heartbeat lost" in vehicle.health().detail, 3.0), vehicle.health()
    assert vehicle.health().state == HealthState.FAULT
    vehicle.safe_stop()  # must not raise with the link down
    peer.send(cmd="resume")
    assert wait_until(lambda: vehicle.health().state == HealthState.OK, 3.0), vehicle.health()


def test_no_autopilot_is_missing(tmp_path: Path) -> None:
    cfg = tmp_path / "hal.yaml"
    cfg.write_text(f'devices:\n  vehicle: {{driver: ardusub, url: "udpin:127.0.0.1:{free_udp_port()}"}}\n')
    vehicle = ArdusubVehicle(_params(cfg), MonotonicClock().now)
    vehicle.connect()
    try:
        h = vehicle.health()
        assert h.state == HealthState.MISSING and "no heartbeat" in h.detail
        assert np.isnan(vehicle.navigation().t)
    finally:
        vehicle.disconnect()


def test_manual_control_mode(tmp_path: Path) -> None:
    port = free_udp_port()
    peer = Peer("hal.testing.ardusub_peer", "--url", f"udpout:127.0.0.1:{port}", "--heartbeat-rate", "5")
    cfg = tmp_path / "hal.yaml"
    cfg.write_text(f'devices:\n  vehicle: {{driver: ardusub, url: "udpin:127.0.0.1:{port}", arm_mode: MANUAL, '
                   'command: manual_control, max_speed: 1.0, max_yaw_rate: 0.5}\n')
    vehicle = ArdusubVehicle(_params(cfg), MonotonicClock().now)
    vehicle.connect()
    try:
        assert wait_until(lambda: vehicle.health().state == HealthState.OK, 5.0), vehicle.health()
        vehicle.arm()
        assert wait_until(lambda: vehicle.armed, 3.0)
        assert vehicle.health().info["ardusub"]["mode"] == "MANUAL"

        def moving() -> bool:
            vehicle.command_body_velocity(np.array([0.4, 0.0, -0.2, 0.0, 0.0, 0.25]))
            v = vehicle.navigation().body_velocity
            return v is not None and abs(v[0] - 0.4) < 0.01 and abs(v[2] + 0.2) < 0.01

        assert wait_until(moving, 3.0), vehicle.navigation()
    finally:
        vehicle.disconnect()
        peer.stop()


def test_manual_control_axes() -> None:
    from hal.drivers.ardusub import manual_control_axes

    assert manual_control_axes(np.array([0.5, -1.0, 0.0, 0.25]), 1.0, 0.5) == (500, -1000, 500, 500)
    assert manual_control_axes(np.array([3.0, 0.0, 1.0, -9.0]), 1.0, 0.5) == (1000, 0, 0, -1000)  # clipped; down = z 0
