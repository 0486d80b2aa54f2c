"""CiA 402 drives described by the EDS files vendors ship: no 0x6075, no 0x603F,
TPDO communication records without an event timer, TPDOs on change or on
SYNC (hal/data/cia402_vendor_like.eds), against the drive simulator in another
process; unusable EDS files; the simulator's refusals."""

from __future__ import annotations

import math
import time
from pathlib import Path

import canopen
import numpy as np
import pytest

from hal.config import load_hal_config
from hal.drivers.arm_canopen import CanopenArm
from hal.drivers.canbus import CanopenBus, open_can_bus
from hal.drivers.canopen_od import EdsError
from hal.drivers.cia402 import State
from hal.drivers.realtime import MonotonicClock
from hal.interfaces import HealthState
from hal.testing.peers import CAN_GROUP, ROOT, wait_until

VENDOR = ROOT / "hal" / "data" / "cia402_vendor_like.eds"
BROKEN = ROOT / "hal" / "data" / "test_eds"
DRIVE = "counts_per_rad: 1000.0, velocity_units_per_rad_s: 1000.0, max_velocity: 1.0"


#: Heartbeat and stale-reading limits (s) of the drives here: as short as a test needs,
#: long enough for a loaded test machine (the simulated drives' process can stall).
WATCH_S = 0.4


def arm_config(
    tmp_path: Path, port: int, *, eds: Path = VENDOR, extra: str = "", bus_extra: str = "", nodes=(1, 2)
) -> dict:
    joints = "\n".join(f"      - {{name: j{n}, node_id: {n}, {DRIVE}}}" for n in nodes)
    cfg = tmp_path / "hal.yaml"
    cfg.write_text(f"""\
buses:
  can0: {{interface: udp_multicast, channel: "{CAN_GROUP}", port: {port}{bus_extra}}}
devices:
  vehicle: {{driver: ardusub, url: "udpin:127.0.0.1:9"}}
  arm:
    driver: canopen_arm
    bus: can0
    eds: {eds}
    heartbeat_period: 0.02
    heartbeat_timeout: {WATCH_S}
    stale_timeout: {WATCH_S}
{extra}
    joints:
{joints}
""")
    config = load_hal_config(cfg)
    return {"bus": config.buses["can0"], "arm": config.devices["arm"].params}


def open_bus(bc) -> tuple[CanopenBus, MonotonicClock]:  # noqa: ANN001
    clock = MonotonicClock()
    return CanopenBus(
        open_can_bus(bc.interface, bc.channel, **bc.options), clock.now, sync_period=bc.sync_period
    ), clock


def states(arm: CanopenArm) -> list:
    return [d.reading().state for d in arm.drives]


@pytest.mark.peer
@pytest.mark.slow
def test_on_change_drive_in_steady_motion_is_not_stale(tmp_path, can_port, drive_sim_with) -> None:  # noqa: ANN001
    drive_sim_with("1,2", VENDOR)
    cfg = arm_config(tmp_path, can_port, extra="    rated_current_a: 2.0")
    bus, clock = open_bus(cfg["bus"])
    arm = CanopenArm(bus, cfg["arm"], clock.now)
    try:
        arm.connect()
        d = arm.drives[0]
        assert d.setup.transmission == "on_change"  # auto: no event timer, no SYNC on this bus
        assert any("0x6075" in n for n in d.setup.notes) and any("event timer" in n for n in d.setup.notes)
        assert d.setup.rated_current_a == 2.0  # from the config: the EDS has no 0x6075
        assert wait_until(lambda: arm.health().state == HealthState.OK, 2.0), arm.health()
        arm.enable()
        assert wait_until(lambda: states(arm) == [State.OPERATION_ENABLED] * 2, 3.0), states(arm)
        arm.command_joint_velocity(np.array([0.4, 0.0]))  # joint 2 holds still: nothing of it changes
        assert wait_until(lambda: abs(arm.joint_state().velocity[0] - 0.4) < 1e-3, 2.0)
        seen = []
        t_end = time.monotonic() + 3 * WATCH_S  # several stale limits of steady motion
        while time.monotonic() < t_end:
            seen.append(arm.health())
            time.sleep(0.02)
        assert all(h.state == HealthState.OK for h in seen), [h.detail for h in seen if h.detail]
        js = arm.joint_state()
        assert js.fault is None and clock.now() - js.t < 0.1  # current: stamped by the heartbeat
        assert math.isfinite(js.current[0]) and js.current[0] > 0
    finally:
        arm.disconnect()
        bus.close()


@pytest.mark.peer
@pytest.mark.slow
def test_sync_drive_follows_the_sync_producer_and_goes_stale_without_it(tmp_path, can_port, drive_sim_with) -> None:  # noqa: ANN001
    drive_sim_with("1,2", VENDOR)
    cfg = arm_config(tmp_path, can_port, extra="    transmission: sync", bus_extra=", sync_period: 0.02")
    bus, clock = open_bus(cfg["bus"])
    arm = CanopenArm(bus, cfg["arm"], clock.now)
    try:
        arm.connect()
        assert arm.drives[0].setup.transmission == "sync"
        assert wait_until(lambda: arm.health().state == HealthState.OK, 2.0), arm.health()
        t0 = arm.drives[0].reading().t_status
        assert wait_until(lambda: arm.drives[0].reading().t_status > t0 + 0.1, 1.0)  # keeps coming, one per SYNC
        assert math.isnan(arm.joint_state().current[0])  # no 0x6075 and no rated_current_a: unknown, not made up
        bus.network.sync.stop()  # no more SYNC: nothing more from the drives
        assert wait_until(lambda: "stale statusword PDO" in arm.health().detail, 1.0), arm.health()
    finally:
        arm.disconnect()
        bus.close()


@pytest.mark.parametrize(
    "eds, message",
    [
        (BROKEN / "io_module_cia401.eds", "describes a CiA 401 device (device type 0x000F0191), not a CiA 402 drive"),
        (BROKEN / "garbage.eds", "not a readable EDS/DCF file (MissingSectionHeaderError"),
        (
            BROKEN / "bad_datatype.eds",
            "0x606C velocity actual value has data type VISIBLE_STRING (0x0009), CiA 301/402 say INTEGER32",
        ),
    ],
)
def test_unusable_eds_names_device_node_and_file(tmp_path, can_port, eds, message) -> None:  # noqa: ANN001
    cfg = arm_config(tmp_path, can_port, eds=eds)
    bus, clock = open_bus(cfg["bus"])
    try:
        with pytest.raises(EdsError) as err:
            CanopenArm(bus, cfg["arm"], clock.now)
        text = str(err.value)  # the HAL config's field first (file:line:column), then device, node and file
        assert "hal.yaml:" in text.split(": devices.arm.eds: ")[0]
        assert f": devices.arm.eds: arm joint j1 (node 1): EDS {eds}: " in text and message in text
    finally:
        bus.close()


def test_bad_data_type_also_reports_the_undefined_type(tmp_path) -> None:  # noqa: ANN001
    from hal.drivers.canopen_od import load_drive_od

    with pytest.raises(EdsError, match=r"0x6041 statusword has an undefined data type"):
        load_drive_od(BROKEN / "bad_datatype.eds", 3, "gripper motor palm")


@pytest.mark.peer
@pytest.mark.slow
def test_the_simulated_drive_refuses_what_drives_refuse(tmp_path, can_port, drive_sim_with) -> None:  # noqa: ANN001
    drive_sim_with("4", VENDOR)
    net = canopen.Network(open_can_bus("udp_multicast", CAN_GROUP, port=can_port, hop_limit=0))
    net.connect()
    try:
        node = net.add_node(4, str(VENDOR))
        hb: list = []
        net.subscribe(0x704, lambda *a: hb.append(a))
        pdos: list = []
        net.subscribe(0x184, lambda *a: pdos.append(a))
        time.sleep(0.3)
        assert hb == []  # silent until asked: no heartbeat before 0x1017 is written
        node.sdo[0x1017].raw = 20
        assert wait_until(lambda: len(hb) > 3, 1.0)
        with pytest.raises(canopen.SdoAbortedError) as err:
            node.sdo.download(0x6075, 0, b"\x10\x27\x00\x00")  # the EDS has no 0x6075: neither has the drive
        assert err.value.code == 0x06020000
        with pytest.raises(canopen.SdoAbortedError) as err:
            node.sdo[0x6060].raw = 7  # interpolated position: not supported
        assert err.value.code == 0x06090030
        with pytest.raises(canopen.SdoAbortedError) as err:
            node.sdo[0x1A00][1].raw = 0x60640020  # remap while the PDO is valid
        assert err.value.code == 0x06040043
        with pytest.raises(canopen.SdoAbortedError):
            node.sdo[0x6041].raw = 0  # read-only
        with pytest.raises(KeyError):
            node.sdo[0x1800][5]  # no event timer in this file  # noqa: B018
        node.nmt.send_command(0x01)
        time.sleep(0.3)
        assert pdos == []  # on change: nothing is sent while nothing changes, not even at NMT start
    finally:
        net.disconnect()


@pytest.mark.peer
@pytest.mark.slow
def test_two_sessions_on_the_same_drives(tmp_path, can_port, drive_sim_with) -> None:  # noqa: ANN001
    """A clean close leaves the drives takeable; a crash (no close) leaves them in
    FAULT with a decoded reason, which reset_faults() clears."""
    drive_sim_with("1,2", VENDOR)
    # a 0.5 s watch (the default): a shorter one can trip on a loaded test machine, where
    # the simulated drives' process may not run for a few tenths of a second (hence also
    # arm_config's 0.4 s heartbeat and stale limits)
    cfg = arm_config(tmp_path, can_port, extra="    rated_current_a: 2.0\n    host_heartbeat_timeout: 0.5")

    def session():  # noqa: ANN202
        bus, clock = open_bus(cfg["bus"])
        arm = CanopenArm(bus, cfg["arm"], clock.now)
        arm.connect()
        return bus, arm

    bus, arm = session()
    assert arm.drives[0].setup.host_watch_s == pytest.approx(0.5)  # the crash bound, read back from 0x1016
    arm.enable()
    assert wait_until(lambda: states(arm) == [State.OPERATION_ENABLED] * 2, 3.0), (states(arm), arm.health())
    arm.command_joint_velocity(np.array([0.3, -0.3]))
    assert wait_until(lambda: abs(arm.joint_state().velocity[0] - 0.3) < 1e-3, 2.0)
    arm.disconnect()  # clean close: stop watching us, PRE-OPERATIONAL, then our heartbeat stops
    bus.close()
    time.sleep(1.0)  # well past the drives' 0.5 s heartbeat watch
    bus, arm = session()
    try:
        assert wait_until(lambda: arm.health().state == HealthState.OK, 2.0), arm.health()
        assert states(arm) == [State.SWITCH_ON_DISABLED] * 2
        arm.enable()
        assert wait_until(lambda: states(arm) == [State.OPERATION_ENABLED] * 2, 3.0), (states(arm), arm.health())
    finally:  # now the crash: no close, the heartbeat just stops
        bus.stop_host_heartbeat()
        bus.close()
    time.sleep(1.0)  # past the 0.5 s watch: the drives fault (EMCY 0x8130)
    bus, arm = session()
    try:
        assert arm.health().state == HealthState.FAULT
        detail = arm.health().detail
        assert "arm joint j1 (node 1): CiA 402 FAULT, EMCY 0x8130 (life guard or heartbeat error" in detail
        assert "error register 0x11 (generic, communication)" in detail  # read over SDO: the EMCY went out before
        reports = arm.reset_faults()
        assert len(reports) == 2 and "EMCY 0x8130" in reports[0]
        assert wait_until(lambda: arm.health().state == HealthState.OK, 2.0), arm.health()
        assert states(arm) == [State.SWITCH_ON_DISABLED] * 2  # reset, not enabled
    finally:
        arm.disconnect()
        bus.close()


@pytest.mark.slow
def test_maris_run_with_an_unusable_eds_names_it_without_a_traceback(tmp_path) -> None:  # noqa: ANN001
    import subprocess
    import sys

    cfg = tmp_path / "hal.yaml"
    cfg.write_text(f"""\
buses:
  can0: {{interface: udp_multicast, channel: "{CAN_GROUP}", port: 45991}}
devices:
  vehicle: {{driver: sim}}
  arm: {{driver: canopen_arm, bus: can0, eds: {BROKEN / "garbage.eds"}, joints: [{{name: j1_shoulder_yaw, node_id: 5}}]}}
""")
    res = subprocess.run(
        [sys.executable, "-m", "mission.cli", "run", str(ROOT / "missions" / "survey_only.yaml"), "--hal", str(cfg)],
        cwd=ROOT,
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert res.returncode == 2 and "Traceback" not in res.stderr
    assert (
        f"arm joint j1_shoulder_yaw (node 5): EDS {BROKEN / 'garbage.eds'}: not a readable EDS/DCF file" in res.stderr
    )
