"""HAL conformity, sensor outputs, injected faults, real-time pacing."""

from __future__ import annotations

import math
import time

import numpy as np
import pytest
from simtest_util import PERFECT_TRACKING, run

from hal.interfaces import Arm, Backend, ForceTorqueSensor, Gripper, HealthState, TargetDetector, Vehicle


def test_devices_implement_the_hal(make_sim):
    sim = make_sim()
    assert isinstance(sim, Backend)
    d = sim.devices
    assert isinstance(d.vehicle, Vehicle) and isinstance(d.arm, Arm)
    assert isinstance(d.gripper, Gripper) and isinstance(d.detector, TargetDetector)
    assert isinstance(d.wrench_sensor, ForceTorqueSensor)
    assert set(d.by_role()) == {"vehicle", "arm", "gripper", "detector", "wrench_sensor", *d.operators}
    assert set(d.operators) == {"gamepad", "foxglove", "keyboard"}  # the teleop nodes' inputs
    assert make_sim(overrides={"ft.present": False}).devices.wrench_sensor is None
    assert len(d.arm.joint_names) == sim.model.n_joints
    assert "cylindrical" in d.gripper.preshapes
    for dev in d.by_role().values():
        assert dev.health().state is HealthState.OK, dev.health()
    with pytest.raises(ValueError):
        d.gripper.preshape("claw")
    with pytest.raises(ValueError):
        d.arm.command_joint_velocity(np.zeros(3))
    sim.close()  # safe-stops everything, never raises


def test_navigation_readings(make_sim):
    sim = make_sim("pool_fixed", 3, {"vehicle.disturbance_std": [0] * 6})
    run(sim, 2.0)
    nav = sim.devices.vehicle.navigation()
    truth = sim.vehicle.eta
    assert nav.t == pytest.approx(2.0)
    assert np.allclose(nav.position, truth[:3], atol=0.05)
    assert np.allclose(nav.attitude, truth[3:], atol=0.05)
    assert nav.depth == pytest.approx(truth[2], abs=0.03)
    assert nav.altitude == pytest.approx(4.0 - truth[2], abs=0.05)
    assert nav.body_velocity.shape == (6,) and 1.6 <= nav.velocity_t <= 2.0  # DVL at 5 Hz
    # angular-rate noise is there (it matters for the arm compensation)
    rates = []
    for _ in range(100):
        sim.advance(0.01)
        rates.append(sim.devices.vehicle.navigation().body_velocity[3:])
    std = np.std(np.array(rates), axis=0)
    assert np.all(std > 0.5 * sim.params["ahrs.rate_noise_std_rad_s"])


def test_no_dvl_gives_no_velocity(make_sim):
    sim = make_sim("pool_no_dvl")
    run(sim, 1.0)
    nav = sim.devices.vehicle.navigation()
    assert nav.body_velocity is None and nav.velocity_t is None and nav.altitude is None
    assert sim.devices.vehicle.health().info["dvl"] == "absent"


def test_dvl_dropout_from_scenario_and_injection(make_sim):
    sim = make_sim("pool_fixed", 0, {"dvl.dropouts": [[1.0, 3.0]], "dvl.dropout_probability": 0.0})
    run(sim, 2.5)
    nav = sim.devices.vehicle.navigation()
    assert nav.velocity_t < 1.0
    assert sim.devices.vehicle.health().state is HealthState.DEGRADED
    run(sim, 1.0)
    assert sim.devices.vehicle.navigation().velocity_t >= 3.0
    assert sim.devices.vehicle.health().state is HealthState.OK
    sim.inject("dvl_dropout", duration=2.0)
    t0 = sim.clock.now()
    run(sim, 1.5)
    assert sim.devices.vehicle.navigation().velocity_t < t0
    run(sim, 1.0)
    assert sim.devices.vehicle.navigation().velocity_t > t0 + 2.0 - 1e-9


def test_joint_fault_stops_the_joint_and_is_reported(make_sim):
    sim = make_sim(overrides=PERFECT_TRACKING)
    arm = sim.devices.arm
    arm.command_joint_velocity(np.full(len(arm.joint_names), 0.1))
    sim.inject("joint_fault", start=0.5, joint="j4_elbow_pitch")
    run(sim, 0.4)
    assert arm.health().state is HealthState.OK
    run(sim, 0.6)
    q_a = arm.joint_state().position.copy()
    run(sim, 0.5)
    js = arm.joint_state()
    assert "j4_elbow_pitch" in js.fault
    assert arm.health().state is HealthState.FAULT
    assert abs(js.position[3] - q_a[3]) < 1e-3 and js.velocity[3] == 0.0
    assert js.position[0] - q_a[0] == pytest.approx(0.05, abs=1e-3)  # the others keep going
    with pytest.raises(ValueError):
        sim.inject("joint_fault", joint=99)
    with pytest.raises(ValueError):
        sim.inject("thruster_fire")


def test_joint_limits_are_enforced(make_sim):
    sim = make_sim(overrides=PERFECT_TRACKING)
    n = sim.model.n_joints
    sim.devices.arm.command_joint_velocity(np.full(n, 10.0))  # also above the velocity limits
    run(sim, 0.1)
    assert np.all(np.abs(sim.arm.qdot) <= sim.model.joint_velocity_limit + 1e-12)
    run(sim, 15.0)
    assert np.allclose(sim.arm.q, sim.model.joint_upper)


def test_ahrs_nan_and_vision_lost(make_sim):
    sim = make_sim()
    sim.inject("ahrs_nan", start=0.5)
    sim.inject("vision_lost", start=0.0)
    run(sim, 1.0)
    assert sim.devices.vehicle.health().state is HealthState.FAULT
    assert np.all(np.isnan(sim.devices.vehicle.navigation().attitude))
    assert sim.devices.detector.latest() is None or sim.devices.detector.latest().t == 0.0
    sim.inject("gripper_fault")
    assert sim.devices.gripper.health().state is HealthState.FAULT


def test_realtime_pacing(make_sim, monkeypatch):
    sim = make_sim(realtime=True)
    t0 = time.monotonic()
    for _ in range(21):
        sim.advance(0.01)
    assert time.monotonic() - t0 >= 0.19
    # without realtime the simulator never waits (checked without a stopwatch)
    sleeps: list[float] = []
    monkeypatch.setattr("sim_backend.backend.time.sleep", sleeps.append)
    fast = make_sim()
    for _ in range(21):
        fast.advance(0.01)
    assert sleeps == []
    paced = make_sim(realtime=True)
    for _ in range(21):
        paced.advance(0.01)
    assert sleeps and sum(sleeps) > 0.0


def test_advance_splits_long_steps(make_sim):
    a = make_sim(overrides=PERFECT_TRACKING)
    b = make_sim(overrides=PERFECT_TRACKING)
    for sim in (a, b):
        sim.devices.vehicle.command_body_velocity(np.array([0.1, 0, 0, 0, 0, 0.1]))
    a.advance(0.1)
    run(b, 0.1)
    assert a.clock.now() == b.clock.now() == pytest.approx(0.1)
    assert np.allclose(a.vehicle.eta, b.vehicle.eta, atol=1e-12)
    with pytest.raises(ValueError):
        a.advance(math.nan)


def test_arm_below_the_floor_is_flagged(make_sim):
    sim = make_sim(overrides=PERFECT_TRACKING)
    run(sim, 0.2)
    assert sim.ground_truth()["arm_below_floor"] is False
    sim.vehicle.eta[2] = 2.5  # the arm hangs 1.88 m below the vehicle: the tool is at 4.38 m, floor at 4 m
    run(sim, 0.2)
    gt = sim.ground_truth()
    assert gt["arm_below_floor"] is True
    assert [e["event"] for e in gt["events"]] == ["arm_below_floor"]
