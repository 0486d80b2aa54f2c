"""Arm and gripper drivers against the CiA 402 simulator in another process
(canopen LocalNode over python-can udp_multicast, host-only)."""

from __future__ import annotations

import threading
import time
from pathlib import Path

import numpy as np
import pytest

from hal.config import load_hal_config
from hal.drivers.arm_canopen import CanopenArm
from hal.drivers.canbus import CanopenBus, open_can_bus
from hal.drivers.cia402 import State
from hal.drivers.gripper_canopen import CanopenGripper
from hal.drivers.realtime import MonotonicClock
from hal.interfaces import GripperMotion, HealthState
from hal.testing.peers import CAN_GROUP, wait_until

pytestmark = pytest.mark.peer

EDS = Path(__file__).resolve().parents[2] / "hal" / "data" / "cia402_minimal.eds"
DRIVE = "counts_per_rad: 1000.0, velocity_units_per_rad_s: 1000.0, max_velocity: 1.0"


@pytest.fixture
def hal_params(tmp_path: Path, can_port: int) -> dict:
    cfg = tmp_path / "hal.yaml"
    cfg.write_text(f"""\
buses:
  can0: {{interface: udp_multicast, channel: "{CAN_GROUP}", port: {can_port}}}
devices:
  vehicle: {{driver: ardusub, url: "udpin:127.0.0.1:9"}}
  arm:
    driver: canopen_arm
    bus: can0
    eds: {EDS}
    heartbeat_period: 0.02
    heartbeat_timeout: 0.4  # short for the tests, long enough for a loaded machine
    joints:
      - {{name: j1, node_id: 1, {DRIVE}}}
      - {{name: j2, node_id: 2, {DRIVE}}}
      - {{name: j3, node_id: 3, {DRIVE}}}
  gripper:
    driver: canopen_gripper
    bus: can0
    eds: {EDS}
    motors:
      distal: {{node_id: 10, {DRIVE}}}
      proximal: {{node_id: 11, {DRIVE}}}
      palm: {{node_id: 12, {DRIVE}}}
    preshapes: {{cylindrical: 0.0, parallel: 0.6}}
""")
    config = load_hal_config(cfg)
    return {
        "bus": config.buses["can0"],
        "arm": config.devices["arm"].params,
        "gripper": config.devices["gripper"].params,
    }


@pytest.fixture
def canbus(drive_sim, hal_params):  # noqa: ANN001, ANN201
    clock = MonotonicClock()
    bc = hal_params["bus"]
    bus = CanopenBus(open_can_bus(bc.interface, bc.channel, **bc.options), clock.now)
    yield bus, clock
    bus.close()


@pytest.fixture
def arm(canbus, hal_params):  # noqa: ANN001, ANN201
    bus, clock = canbus
    arm = CanopenArm(bus, hal_params["arm"], clock.now)
    arm.connect()
    yield arm
    arm.disconnect()


def states(arm: CanopenArm) -> list:
    return [d.reading().state for d in arm.drives]


@pytest.mark.slow
def test_arm_comes_up_disabled_then_follows_velocity(arm: CanopenArm) -> None:
    assert wait_until(lambda: arm.health().state == HealthState.OK, 3.0), arm.health()
    assert states(arm) == [State.SWITCH_ON_DISABLED] * 3
    info = arm.health().info["parts"][0]
    assert info["nmt"] == "OPERATIONAL" and info["heartbeat_age_s"] < 0.4
    arm.command_joint_velocity(np.array([0.5, -0.2, 0.0]))  # ignored while disabled
    arm.enable()
    assert wait_until(lambda: states(arm) == [State.OPERATION_ENABLED] * 3, 3.0), states(arm)
    arm.command_joint_velocity(np.array([0.5, -0.2, 0.0]))
    assert wait_until(lambda: np.allclose(arm.joint_state().velocity, [0.5, -0.2, 0.0], atol=1e-3), 2.0)
    p0 = arm.joint_state().position
    assert wait_until(lambda: arm.joint_state().position[0] > p0[0] + 0.05, 2.0)
    js = arm.joint_state()
    assert js.position[1] < p0[1] and js.fault is None
    assert 0 <= arm._clock() - js.t < 0.1  # noqa: SLF001 - freshness of the stamp
    arm.command_joint_velocity(np.array([np.nan, 0.0, 0.0]))  # NaN reference: safe state
    assert wait_until(lambda: states(arm) == [State.SWITCH_ON_DISABLED] * 3, 3.0), states(arm)


@pytest.mark.slow
def test_drive_fault_is_reported_stops_all_and_reset_works(arm: CanopenArm, drive_sim) -> None:  # noqa: ANN001
    arm.enable()
    assert wait_until(lambda: states(arm) == [State.OPERATION_ENABLED] * 3, 3.0)
    arm.command_joint_velocity(np.array([0.3, 0.3, 0.3]))
    drive_sim.send(cmd="fault", node=2, code=0x2310)
    assert wait_until(lambda: arm.health().state == HealthState.FAULT, 2.0)
    assert (
        "arm joint j2 (node 2): CiA 402 FAULT, EMCY 0x2310 (continuous over-current), error register 0x03 (generic, current)"
        in arm.health().detail
    )
    assert wait_until(lambda: states(arm) == [State.SWITCH_ON_DISABLED, State.FAULT, State.SWITCH_ON_DISABLED], 3.0), (
        states(arm)
    )
    assert "EMCY 0x2310" in arm.joint_state().fault
    arm.command_joint_velocity(np.array([0.3, 0.3, 0.3]))  # ignored: not enabled
    assert np.allclose(arm.joint_state().velocity, 0.0, atol=1e-3)
    arm.enable()  # enabling never resets a fault behind the operator's back
    time.sleep(0.3)
    assert states(arm)[1] == State.FAULT and arm.health().state == HealthState.FAULT
    reports = arm.reset_faults()  # the documented reset, then enable
    assert len(reports) == 1 and "node 2" in reports[0] and "EMCY 0x2310" in reports[0]
    arm.enable()
    assert wait_until(lambda: states(arm) == [State.OPERATION_ENABLED] * 3, 3.0), states(arm)
    assert wait_until(lambda: arm.health().state == HealthState.OK, 1.0), arm.health()


@pytest.mark.slow
def test_heartbeat_loss_is_a_fault_and_takes_all_joints_to_safe_state(arm: CanopenArm, drive_sim) -> None:  # noqa: ANN001
    arm.enable()
    assert wait_until(lambda: states(arm) == [State.OPERATION_ENABLED] * 3, 3.0)
    drive_sim.send(cmd="silence", node=3)
    assert wait_until(lambda: "heartbeat lost" in arm.health().detail, 2.0), arm.health()
    assert arm.health().state == HealthState.FAULT
    assert wait_until(lambda: states(arm)[:2] == [State.SWITCH_ON_DISABLED] * 2, 3.0), states(arm)
    drive_sim.send(cmd="resume", node=3)
    assert wait_until(lambda: "enable to resume" in arm.health().detail, 2.0), arm.health()
    arm.enable()
    assert wait_until(
        lambda: arm.health().state == HealthState.OK and states(arm) == [State.OPERATION_ENABLED] * 3, 3.0
    )


def test_disconnect_goes_through_quick_stop(arm: CanopenArm) -> None:
    arm.enable()
    assert wait_until(lambda: states(arm) == [State.OPERATION_ENABLED] * 3, 3.0)
    arm.command_joint_velocity(np.array([1.0, 1.0, 1.0]))
    assert wait_until(lambda: arm.joint_state().velocity[0] > 0.9, 2.0)
    seen: list = []
    drive = arm.drives[0]
    original = drive._on_tpdo  # noqa: SLF001 - record every received state

    def spy(pdo_map) -> None:  # noqa: ANN001
        original(pdo_map)
        seen.append(drive.reading().state)

    for num in (1,):
        drive.node.tpdo[num].callbacks[:] = [spy if cb == original else cb for cb in drive.node.tpdo[num].callbacks]
    done = threading.Event()
    threading.Thread(target=lambda: (arm.disconnect(), done.set()), daemon=True).start()
    assert done.wait(3.0)
    assert State.QUICK_STOP_ACTIVE in seen, seen
    assert seen.index(State.QUICK_STOP_ACTIVE) < len(seen) - 1 - seen[::-1].index(State.SWITCH_ON_DISABLED)
    assert seen[-1] == State.SWITCH_ON_DISABLED


@pytest.mark.slow
def test_gripper_preshape_close_on_object_and_open(canbus, hal_params, drive_sim) -> None:  # noqa: ANN001
    bus, clock = canbus
    g = CanopenGripper(bus, hal_params["gripper"], clock.now)
    g.connect()
    try:
        assert wait_until(lambda: g.health().state == HealthState.OK, 3.0), g.health()
        g.preshape("parallel")
        assert wait_until(
            lambda: g.state().motion == GripperMotion.IDLE and abs(g.state().positions[2] - 0.6) < 0.03, 3.0
        ), g.state()
        drive_sim.send(cmd="contact", node=10, counts=300)  # object at 0.3 rad for the distal group
        drive_sim.send(cmd="contact", node=11, counts=400)
        g.close(current_limit=0.5)
        assert g.state().motion == GripperMotion.CLOSING
        assert wait_until(lambda: g.state().motion == GripperMotion.HOLDING, 4.0), g.state()
        s = g.state()
        assert s.positions[0] == pytest.approx(0.3, abs=0.02) and s.positions[1] == pytest.approx(0.4, abs=0.02)
        g.open()
        assert wait_until(lambda: g.state().motion == GripperMotion.IDLE, 4.0), g.state()
        assert np.allclose(g.state().positions[:2], 0.0, atol=0.03)
        with pytest.raises(ValueError, match="unknown preshape `power`"):
            g.preshape("power")
        drive_sim.send(cmd="fault", node=11, code=0x7500)
        assert wait_until(lambda: g.health().state == HealthState.FAULT, 2.0)
        assert "gripper motor proximal (node 11): CiA 402 FAULT, EMCY 0x7500" in g.state().fault
        with pytest.raises(RuntimeError, match="gripper not usable"):
            g.close(current_limit=0.5)  # a motion command never resets a fault
        assert wait_until(
            lambda: (
                [d.reading().state for d in g.drives.values()]
                == [State.SWITCH_ON_DISABLED, State.FAULT, State.SWITCH_ON_DISABLED]
            ),
            2.0,
        )
        g.reset_fault()
        assert wait_until(lambda: g.health().state == HealthState.OK, 3.0), g.health()
        g.open()
        assert g.state().motion == GripperMotion.OPENING
    finally:
        g.disconnect()


@pytest.mark.slow
def test_drives_fault_by_themselves_when_the_host_dies(arm: CanopenArm, canbus) -> None:  # noqa: ANN001
    bus, _ = canbus
    arm.enable()
    assert wait_until(lambda: states(arm) == [State.OPERATION_ENABLED] * 3, 3.0)
    arm.command_joint_velocity(np.array([0.2, 0.2, 0.2]))
    # play a hung host: no more heartbeat, no more RPDOs (the receive side keeps listening)
    bus.stop_host_heartbeat()
    for d in arm.drives:
        bus.unregister(d)
    bus.unregister(arm)
    # CiA 301 default error behaviour: EMCY 0x8130, then PRE-OPERATIONAL (no more PDOs), CiA 402 FAULT
    assert wait_until(lambda: "NMT state PRE-OPERATIONAL" in arm.health().detail, 2.0), arm.health()
    detail = arm.health().detail
    assert (
        "EMCY 0x8130 (life guard or heartbeat error" in detail
        and "error register 0x11 (generic, communication)" in detail
    )
    for d in arm.drives:  # what the drives say when asked (SDO works in PRE-OPERATIONAL)
        assert d.node.sdo[0x6041].raw & 0x4F == 0x08  # FAULT
        assert wait_until(lambda d=d: d.node.sdo[0x606C].raw == 0, 1.0)  # stopped
