"""Factory and `maris hal check` on a whole field config whose devices are
simulator processes: CiA 402 drives on udp_multicast CAN, an ArduSub-like
MAVLink peer, a DVL on 127.0.0.1 TCP."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

from hal.config import load_hal_config
from hal.drivers.backend import RealBackend
from hal.drivers.cia402 import State
from hal.factory import build_backend
from hal.interfaces import HealthState
from hal.testing.peers import CAN_GROUP, ROOT, Peer, free_udp_port, wait_until

EDS = ROOT / "hal" / "data" / "cia402_minimal.eds"
DRIVE = "counts_per_rad: 1000.0, velocity_units_per_rad_s: 1000.0"


@pytest.fixture
def field(tmp_path: Path, drive_sim, can_port: int):  # noqa: ANN001, ANN201
    mav_port = free_udp_port()
    mav = Peer("hal.testing.ardusub_peer", "--url", f"udpout:127.0.0.1:{mav_port}")
    dvl = Peer("hal.testing.nav_sensor_sim", "dvl-tcp", "--rate", "20", "--velocity", "0.3,0.0,0.0")

    def write(arm_nodes: tuple[int, ...] = (1, 2, 3), dvl_port: int | None = None) -> Path:
        joints = "\n".join(f"      - {{name: j{n}, node_id: {n}, {DRIVE}}}" for n in arm_nodes)
        cfg = tmp_path / "field.yaml"
        cfg.write_text(f"""\
buses:
  can0: {{interface: udp_multicast, channel: "{CAN_GROUP}", port: {can_port}}}
devices:
  vehicle:
    driver: ardusub
    url: "udpin:127.0.0.1:{mav_port}"
    heartbeat_timeout: 1.0
    dvl: {{transport: tcp, host: 127.0.0.1, port: {dvl_port or int(dvl.ready)}, timeout: 0.3}}
  arm:
    driver: canopen_arm
    bus: can0
    eds: {EDS}
    joints:
{joints}
  gripper:
    driver: canopen_gripper
    bus: can0
    eds: {EDS}
    motors:
      distal: {{node_id: 10, {DRIVE}}}
      proximal: {{node_id: 11, {DRIVE}}}
      palm: {{node_id: 12, {DRIVE}}}
""")
        return cfg

    yield write
    mav.stop()
    dvl.stop()


def maris(*args: str, timeout: float = 30.0) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "mission.cli", *args], cwd=ROOT, capture_output=True, text=True, timeout=timeout)


def test_real_backend_from_config(field) -> None:  # noqa: ANN001
    backend = build_backend(load_hal_config(field()))
    assert isinstance(backend, RealBackend) and backend.realtime
    backend.open()
    try:
        devs = backend.devices
        assert devs.detector is None and devs.wrench_sensor is None
        assert wait_until(lambda: all(d.health().state == HealthState.OK for d in devs.by_role().values()), 5.0), \
            {r: d.health() for r, d in devs.by_role().items()}
        nav = devs.vehicle.navigation()
        assert nav.body_velocity[0] == pytest.approx(0.3) and nav.altitude == pytest.approx(3.0)  # from the DVL
        t0 = backend.clock.now()
        for _ in range(5):
            backend.advance(0.02)
        assert backend.clock.now() - t0 >= 0.1 - 1e-3  # advance() waits for the time to pass
        devs.arm.enable()
        assert wait_until(lambda: all(d.reading().state == State.OPERATION_ENABLED for d in devs.arm.drives), 3.0)
    finally:
        backend.close()
    assert all(d.reading().state == State.SWITCH_ON_DISABLED for d in devs.arm.drives)
    assert all(d.reading().state == State.SWITCH_ON_DISABLED for d in devs.gripper.drives.values())


def test_close_stops_only_connected_devices_and_only_once(field, caplog) -> None:  # noqa: ANN001
    """`maris run` closes the backend when setup fails before the run (nothing
    connected yet) and again after the run: a device that was never connected is
    not commanded, a second close does nothing, and neither logs a failure."""

    def counting(backend: RealBackend) -> dict[str, int]:
        stops = {role: 0 for role in backend.devices.by_role()}
        for role, dev in backend.devices.by_role().items():
            original = dev.safe_stop

            def safe_stop(role=role, original=original) -> None:  # noqa: ANN001
                stops[role] += 1
                original()

            dev.safe_stop = safe_stop
        return stops

    never_opened = build_backend(load_hal_config(field()))
    stops = counting(never_opened)
    never_opened.close()
    never_opened.close()
    assert set(stops.values()) == {0}
    backend = build_backend(load_hal_config(field()))
    stops = counting(backend)
    backend.open()
    backend.close()
    backend.close()
    assert set(stops.values()) == {1}
    assert [r.getMessage() for r in caplog.records if r.levelname in ("ERROR", "CRITICAL")] == []


def test_hal_check_prints_every_device_state(field) -> None:  # noqa: ANN001
    res = maris("hal", "check", str(field()), "--wait", "3")
    assert res.returncode == 0, res.stdout + res.stderr
    out = res.stdout
    assert "all devices healthy" in out
    assert "nmt=OPERATIONAL" in out and "cia402=SWITCH ON DISABLED" in out and "heartbeat_age_s=" in out
    assert "mode=MANUAL" in out and "armed=False" in out and "ATTITUDE" in out
    assert "dvl:" in out and "rate_hz=" in out


def test_hal_check_fails_on_missing_drive_and_missing_dvl(field) -> None:  # noqa: ANN001
    res = maris("hal", "check", str(field(arm_nodes=(1, 2, 5))))
    assert res.returncode == 1
    assert "FAILED to connect" in res.stderr and "j5 (node 5)" in res.stderr
    res = maris("hal", "check", str(field(dvl_port=free_udp_port())), "--wait", "1")
    assert res.returncode == 1, res.stdout
    assert "NOT healthy: vehicle" in res.stdout and "DVL: cannot open 127.0.0.1" in res.stdout


def test_hal_check_invalid_config_names_the_place(tmp_path: Path) -> None:
    cfg = tmp_path / "bad.yaml"
    cfg.write_text("devices:\n  vehicle: {driver: simm}\n  arm: {driver: sim}\n")
    res = maris("hal", "check", str(cfg))
    assert res.returncode == 2
    assert "bad.yaml:2:21: devices.vehicle.driver: unknown driver `simm` (did you mean `sim`?)" in res.stderr
    assert "Traceback" not in res.stderr


def test_hal_check_on_the_simulator_config() -> None:
    pytest.importorskip("sim_backend")
    res = maris("hal", "check", "hal/configs/sim.yaml", "--wait", "1")
    assert res.returncode == 0, res.stdout + res.stderr
    assert "vehicle        OK" in res.stdout and "arm            OK" in res.stdout
    assert "all devices healthy" in res.stdout


def test_cli_import_stays_light() -> None:
    code = "import sys, mission.commands.hal; print('numpy' in sys.modules, 'canopen' in sys.modules)"
    out = subprocess.run([sys.executable, "-c", code], cwd=ROOT, capture_output=True, text=True, timeout=30).stdout
    assert out.strip() == "False False"


def test_sim_backend_from_config_keeps_only_configured_roles(tmp_path: Path) -> None:
    pytest.importorskip("sim_backend")
    backend = build_backend(load_hal_config(ROOT / "hal" / "configs" / "sim.yaml"), seed=3)
    try:
        assert set(backend.devices.by_role()) == {"vehicle", "arm", "gripper", "detector", "wrench_sensor"}
        assert not backend.realtime
    finally:
        backend.close()
    cfg = tmp_path / "sim.yaml"
    cfg.write_text("devices:\n  vehicle: {driver: sim}\n  arm: {driver: sim}\nsim: {scenario: pool_clear}\n")
    backend = build_backend(load_hal_config(cfg))
    try:
        assert set(backend.devices.by_role()) == {"vehicle", "arm"}
    finally:
        backend.close()
