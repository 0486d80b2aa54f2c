"""The Ping echosounder driver (brping) against the ping-protocol peer in another
process, and the vehicle's altitude sources: DVL, Ping, ArduSub's rangefinder."""

from __future__ import annotations

import time
from collections.abc import Iterator
from pathlib import Path

import pytest

from hal.drivers.ping_altimeter import PingAltimeter
from hal.drivers.realtime import MonotonicClock
from hal.drivers.vehicle_ardusub import ArdusubVehicle
from hal.interfaces import HealthState
from hal.testing.ardusub_fw import SEABED
from hal.testing.peers import Peer, free_tcp_port, peer_report, wait_until
from mission.runtime.safety import classify_health

pytestmark = pytest.mark.peer


def ping_params(peer: Peer, transport: str, **extra: object) -> dict:
    base = {"transport": transport, "rate_hz": 10.0, "timeout": 0.6, "min_confidence": 50, "offset_m": 0.0}
    if transport == "serial":
        base.update(device=peer.ready, baudrate=115200)
    else:
        base.update(host="127.0.0.1", port=int(peer.ready))
    return {**base, **extra}


@pytest.fixture(params=["serial", "udp"])
def sonar(request: pytest.FixtureRequest) -> Iterator[tuple[PingAltimeter, Peer]]:
    peer = Peer("hal.testing.ping_peer", "--transport", request.param, "--altitude", "2.5")
    ping = PingAltimeter(
        ping_params(peer, request.param, offset_m=-0.1, speed_of_sound_mps=1500.0), MonotonicClock().now
    )
    ping.connect()
    yield ping, peer
    ping.close()
    peer.stop()


def test_distance_is_asked_for_and_becomes_the_altitude(sonar: tuple[PingAltimeter, Peer]) -> None:
    ping, peer = sonar
    assert wait_until(lambda: ping.health().state == HealthState.OK, 4.0), ping.health()
    alt, t = ping.altitude()
    assert alt == pytest.approx(2.4, abs=0.005) and t is not None
    time.sleep(0.5)
    rep = peer_report(peer)
    assert rep["requests"].get("1212", 0) >= 4 and not rep["streaming"]  # asked for, never streamed
    assert rep["speed_of_sound"] == 1500000
    assert ping.health().info["answers_hz"] == pytest.approx(10.0, rel=0.3)


def test_low_confidence_is_no_altitude(sonar: tuple[PingAltimeter, Peer]) -> None:
    ping, peer = sonar
    assert wait_until(lambda: ping.altitude()[0] is not None, 4.0)
    peer.send(cmd="altitude", m=1.0, confidence=20)
    assert wait_until(lambda: ping.health().state == HealthState.DEGRADED, 2.0)
    assert "confidence 20 % below 50 %" in ping.health().detail
    assert ping.altitude()[0] == pytest.approx(2.4, abs=0.005)  # the last confident one, ageing out
    peer.send(cmd="altitude", m=1.0, confidence=90)
    assert wait_until(lambda: ping.altitude()[0] == pytest.approx(0.9, abs=0.005), 2.0)


def test_a_stalled_sonar_is_lost_a_corrupting_one_counted_never_a_traceback(sonar: tuple[PingAltimeter, Peer]) -> None:
    ping, peer = sonar
    assert wait_until(lambda: ping.health().state == HealthState.OK, 4.0)
    peer.send(cmd="corrupt", count=3)
    assert wait_until(lambda: ping.unanswered >= 3, 4.0)  # bad checksums: no answer in time, counted
    assert wait_until(lambda: ping.health().state == HealthState.OK, 3.0)
    peer.send(cmd="stall")
    assert wait_until(lambda: ping.health().state == HealthState.FAULT, 3.0)  # heard before: lost
    assert "lost: silent" in ping.health().detail
    peer.send(cmd="resume")
    assert wait_until(lambda: ping.health().state == HealthState.OK, 3.0)


def vehicle_params(port: int, **extra: object) -> dict:
    from hal.config import DRIVER_SCHEMAS, _check_mapping  # noqa: PLC0415 - the vehicle entry alone
    from maris_common.yamlsrc import Located

    raw = {"url": f"tcp:127.0.0.1:{port}", "heartbeat_timeout": 2.0, **extra}
    issues: list = []
    params = _check_mapping(Located(raw, "<test>"), (), raw, DRIVER_SCHEMAS["ardusub"][1], Path("."), issues)
    assert not issues, issues
    return params


def test_vehicle_altitude_from_the_ping_then_arduSubs_rangefinder(tmp_path: Path) -> None:
    port = free_tcp_port()
    sub = Peer("hal.testing.ardusub_peer", "--url", f"tcpin:127.0.0.1:{port}")
    sonar = Peer("hal.testing.ping_peer", "--transport", "udp", "--altitude", "1.75")
    vehicle = ArdusubVehicle(vehicle_params(port, ping=ping_params(sonar, "udp")), MonotonicClock().now)
    try:
        vehicle.connect()
        assert wait_until(lambda: vehicle.health().state.usable and "ping" in vehicle.health().info, 8.0)
        assert wait_until(lambda: vehicle.navigation().altitude == pytest.approx(1.75, abs=0.01), 4.0)
        assert vehicle.health().info["ping"]["state"] == "ok"
        sonar.send(cmd="stall")
        rangefinder = SEABED  # the ArduSub peer's DISTANCE_SENSOR at the surface
        assert wait_until(lambda: vehicle.navigation().altitude == pytest.approx(rangefinder, abs=0.05), 3.0)
        h = vehicle.health()
        assert h.info["ping"]["state"] == "fault" and h.info["ardusub"]["state"] == "ok"
        # the fault table: a lost Ping is a lost vehicle sensor, a warning; the vehicle goes on
        assert [(b.kind, b.source, b.ending) for b in classify_health("vehicle", h)] == [
            ("sensor_lost", "ping", "warn")
        ]
    finally:
        vehicle.disconnect()
        sub.stop()
        sonar.stop()


def test_ping_alone_reports_when_nobody_answers(tmp_path: Path) -> None:
    peer = Peer("hal.testing.ping_peer", "--transport", "serial")
    peer.send(cmd="stall")
    ping = PingAltimeter(ping_params(peer, "serial"), MonotonicClock().now)
    ping.connect()
    try:
        time.sleep(1.0)
        h = ping.health()
        assert h.state == HealthState.MISSING and "no answer" in h.detail, h  # never heard: missing
    finally:
        ping.close()
        peer.stop()
