"""Factory and `maris hal check` on a whole field config whose devices are
simulator processes: CiA 402 drives on udp_multicast CAN, an ArduSub-like
MAVLink peer, a DVL on 127.0.0.1 TCP."""

from __future__ import annotations

import json
import re
import subprocess
import sys
from pathlib import Path

import pytest

import sim_backend  # noqa: F401 - registers the simulator with hal.backends
from hal.config import load_hal_config
from hal.drivers.backend import RealBackend
from hal.drivers.cia402 import State
from hal.factory import build_backend
from hal.interfaces import HealthState
from hal.testing.peers import CAN_GROUP, ROOT, Peer, free_udp_port, wait_until

EDS = ROOT / "hal" / "data" / "cia402_minimal.eds"
DRIVE = "counts_per_rad: 1000.0, velocity_units_per_rad_s: 1000.0"
#: The shipped URDF's arm joints, in order.
URDF_JOINTS = (
    "j1_shoulder_yaw",
    "j2_shoulder_pitch",
    "j3_upper_arm_roll",
    "j4_elbow_pitch",
    "j5_forearm_roll",
    "j6_wrist_pitch",
    "j7_wrist_roll",
)


@pytest.fixture
def field(tmp_path: Path, drive_sim, can_port: int):  # noqa: ANN001, ANN201
    mav_port = free_udp_port()
    mav = Peer("hal.testing.ardusub_peer", "--url", f"udpout:127.0.0.1:{mav_port}")
    dvl = Peer("hal.testing.nav_sensor_sim", "dvl-tcp", "--rate", "20", "--velocity", "0.3,0.0,0.0")

    def write(
        arm_nodes: tuple[int, ...] = (1, 2, 3, 4, 5, 6, 7),
        dvl_port: int | None = None,
        names=URDF_JOINTS,
        gripper_eds: Path = EDS,
    ) -> Path:
        joints = "\n".join(f"      - {{name: {name}, node_id: {n}, {DRIVE}}}" for n, name in zip(arm_nodes, names))
        cfg = tmp_path / "field.yaml"
        cfg.write_text(f"""\
buses:
  can0: {{interface: udp_multicast, channel: "{CAN_GROUP}", port: {can_port}}}
devices:
  vehicle:
    driver: ardusub
    url: "udpin:127.0.0.1:{mav_port}"
    heartbeat_timeout: 2.0
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
    eds: {gripper_eds}
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
    return subprocess.run(
        [sys.executable, "-m", "mission.cli", *args], cwd=ROOT, capture_output=True, text=True, timeout=timeout
    )


@pytest.mark.peer
@pytest.mark.slow
def test_real_backend_from_config(field) -> None:  # noqa: ANN001
    backend = build_backend(load_hal_config(field()))
    assert isinstance(backend, RealBackend) and backend.realtime
    backend.open()
    try:
        devs = backend.devices
        assert devs.detector is None and devs.wrench_sensor is None
        assert wait_until(lambda: all(d.health().state == HealthState.OK for d in devs.by_role().values()), 5.0), {
            r: d.health() for r, d in devs.by_role().items()
        }
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


@pytest.mark.peer
@pytest.mark.slow
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


@pytest.mark.peer
@pytest.mark.slow
def test_hal_check_prints_every_device_state(field) -> None:  # noqa: ANN001
    res = maris(
        "hal", "check", str(field()), "--wait", "10"
    )  # returns as soon as all are healthy; 3 s was tight under load
    assert res.returncode == 0, res.stdout + res.stderr
    out = res.stdout
    assert "all devices healthy" in out
    lines = out.splitlines()
    assert [ln.split()[:3] for ln in lines if ln.startswith(("vehicle", "arm", "gripper"))] == [
        ["vehicle", "(ardusub)", "OK"],
        ["arm", "(canopen_arm)", "OK"],
        ["gripper", "(canopen_gripper)", "OK"],
    ]
    row = next(ln for ln in lines if ln.startswith("  j2_shoulder_pitch"))
    assert " ok " in row and "nmt=OPERATIONAL" in row and "cia402=SWITCH ON DISABLED" in row and "hb_age_s=" in row
    assert "transmission=event_timer" in row and "host_hb_watch_s=0.5" in row  # the crash bound, read back
    assert any(
        ln.startswith("  ardusub") and "mode=MANUAL" in ln and "armed=False" in ln and "ATTITUDE" in ln for ln in lines
    )
    assert any(ln.startswith("  dvl") and "rate_hz=" in ln for ln in lines)


@pytest.mark.peer
@pytest.mark.slow
def test_hal_check_lists_every_device_after_failures(field) -> None:  # noqa: ANN001
    """A missing drive, a missing DVL and a gripper EDS that is no drive's: every
    device still gets its row, then exit 1; the table and --json say the same."""
    from hal.check import check_hal
    from mission.commands.hal import format_table

    cfg = field(
        arm_nodes=(1, 2, 3, 4, 5, 6, 8),
        dvl_port=free_udp_port(),
        gripper_eds=ROOT / "hal" / "data" / "test_eds" / "io_module_cia401.eds",
    )
    res = maris("hal", "check", str(cfg), "--wait", "0.5", "--json")
    assert res.returncode == 1 and "Traceback" not in res.stderr, res.stderr
    report = json.loads(res.stdout)
    assert report["ok"] is False
    assert [(d["role"], d["state"]) for d in report["devices"]] == [
        ("vehicle", "missing"),
        ("arm", "failed"),
        ("gripper", "failed"),
    ]
    parts = {p["name"]: p["state"] for p in report["devices"][0]["parts"]}
    assert parts["dvl"] == "missing" and "ardusub" in parts
    table = format_table(check_hal(load_hal_config(cfg), wait=0.5))
    rows = {ln.split()[0]: ln for ln in table.splitlines() if ln and not ln.startswith(" ")}
    assert "FAILED" in rows["arm"] and "arm joint j7_wrist_roll (node 8)" in rows["arm"]
    assert "MISSING" in rows["vehicle"] and "DVL: cannot open 127.0.0.1" in rows["vehicle"]
    assert (
        "FAILED" in rows["gripper"]
        and "io_module_cia401.eds" in rows["gripper"]
        and "not a CiA 402 drive" in rows["gripper"]
    )
    assert "\nNOT healthy: vehicle, arm, gripper\n" in table
    assert "not heard since the start: dvl (" in table and ": devices.vehicle.dvl): DVL: cannot open" in table
    assert table.endswith("`maris run` refuses to start without dvl unless told: --allow-missing dvl")


@pytest.mark.peer
@pytest.mark.slow
def test_hal_check_compares_the_arm_joints_with_the_model(field) -> None:  # noqa: ANN001
    from hal.check import check_hal

    report = check_hal(
        load_hal_config(field(arm_nodes=(1, 2, 3), names=("j1", "j2", "j3"))), wait=1.0, model_joints=list(URDF_JOINTS)
    )
    arm = report.rows[1]
    assert not report.ok and arm.state == "fault"
    assert "the HAL arm has 3 joint(s) (j1, j2, j3), the model (URDF) has 7 (j1_shoulder_yaw" in arm.detail
    names = list(URDF_JOINTS)
    names[2], names[3] = names[3], names[2]
    report = check_hal(load_hal_config(field(names=names)), wait=1.0, model_joints=list(URDF_JOINTS))
    assert "#3 is `j4_elbow_pitch` in the HAL, `j3_upper_arm_roll` in the model (URDF)" in report.rows[1].detail


@pytest.mark.slow
def test_hal_check_invalid_config_names_the_place(tmp_path: Path) -> None:
    cfg = tmp_path / "bad.yaml"
    cfg.write_text("devices:\n  vehicle: {driver: simm}\n  arm: {driver: sim}\n")
    res = maris("hal", "check", str(cfg))
    assert res.returncode == 2
    assert "bad.yaml:2:21: devices.vehicle.driver: unknown driver `simm` (did you mean `sim`?)" in res.stderr
    assert "Traceback" not in res.stderr


@pytest.mark.slow
def test_hal_check_on_the_simulator_config() -> None:
    pytest.importorskip("sim_backend")
    res = maris("hal", "check", "hal/configs/sim.yaml", "--wait", "1")
    assert res.returncode == 0, res.stdout + res.stderr
    assert re.search(r"^vehicle \(sim\) +OK", res.stdout, re.M) and re.search(r"^arm \(sim\) +OK", res.stdout, re.M)
    assert "all devices healthy" in res.stdout


def test_cli_import_stays_light() -> None:
    code = "import sys, mission.commands.hal; print('numpy' in sys.modules, 'canopen' in sys.modules)"
    out = subprocess.run([sys.executable, "-c", code], cwd=ROOT, capture_output=True, text=True, timeout=30).stdout
    assert out.strip() == "False False"


@pytest.mark.slow
def test_the_simulator_is_a_backend_it_registers_itself() -> None:
    """hal never imports sim_backend: without it a `driver: sim` config is refused, naming the fix."""
    code = (
        "import sys\n"
        "from hal.config import load_hal_config\n"
        "from hal.factory import DeviceUnavailable, build_backend\n"
        "try:\n"
        "    build_backend(load_hal_config('hal/configs/sim.yaml'))\n"
        "except DeviceUnavailable as exc:\n"
        "    print('refused:', exc)\n"
        "print('sim_backend' in sys.modules)\n"
    )
    out = subprocess.run([sys.executable, "-c", code], cwd=ROOT, capture_output=True, text=True, timeout=60).stdout
    refused, imported = out.strip().splitlines()
    assert refused.startswith("refused: ") and "import sim_backend" in refused
    assert imported == "False"


def test_sim_backend_from_config_keeps_only_configured_roles(tmp_path: Path) -> None:
    backend = build_backend(load_hal_config(ROOT / "hal" / "configs" / "sim.yaml"), seed=3)
    try:
        devices = {"vehicle", "arm", "gripper", "detector", "wrench_sensor"}
        assert set(backend.devices.by_role()) == devices | {"gamepad", "foxglove", "keyboard"}
        assert set(backend.devices.operators) == {"gamepad", "foxglove", "keyboard"}
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
