"""The BlueROV2 rig's own sensors and gripper in the simulator: the Ping echosounder
as the altitude source, the Alpha's jaw (one motor, grasp confirmed from its
current), the single camera's detections of the pipe."""

from __future__ import annotations

import math

import numpy as np
import pytest
from simtest_util import run

from hal.interfaces import GripperMotion
from sim_backend import SimBackend, load_scenario
from sim_backend.jaw_sim import JawModel, contact_opening_mm, half_gap_m
from sim_backend.ping_sim import PingAltimeter
from sim_backend.rng import child_rng
from sim_backend.scenario import sample_values


@pytest.fixture(scope="module")
def values() -> dict:
    return sample_values(load_scenario("bluerov2_pool"), 0)


# ------------------------------------------------------------------ Ping


def test_ping_reads_the_floor_through_its_beam(values: dict) -> None:
    """Level, the nearest echo is straight down; tilted within half the 25 deg beam it
    still is; beyond, the beam's edge: h / cos(tilt - half beam). Reported as the
    reference point's altitude (the transducer's mount removed)."""
    ping = PingAltimeter({**values, "ping.noise_std_m": 0.0, "ping.filter_time_s": 0.0}, child_rng(0, "ping"))
    eta = np.array([5.0, 4.0, 2.0, 0.0, 0.0, 0.0])
    h = 3.0 - (2.0 + 0.10)
    assert ping.distance(eta, 3.0) == pytest.approx(h)
    tilted = eta.copy()
    tilted[4] = 0.15  # inside the half beam (0.218 rad)
    assert ping.distance(tilted, 3.0) == pytest.approx(3.0 - 2.0 - 0.10 * math.cos(0.15))
    tilted[4] = 0.4
    h_t = 3.0 - 2.0 - 0.10 * math.cos(0.4)
    assert ping.distance(tilted, 3.0) == pytest.approx(h_t / math.cos(0.4 - 0.218))
    ping.p_low = 0.0
    ping.update(0.0, eta, 3.0)
    assert ping.t == 0.0 and ping.altitude == pytest.approx(1.0)  # 3 m floor, reference point at 2 m


def test_ping_is_the_altitude_without_a_dvl_and_blind_close_to_the_floor() -> None:
    over = {
        "vehicle.actuated": [False] * 6,
        "vehicle.start_z_m": 2.0,
        "dvl.dropouts": [[0.0, 1000.0]],  # a DVL without bottom lock: the Ping's altitude is used
    }
    sim = SimBackend(load_scenario("bluerov2_pool", over), 0)
    sim.open()
    run(sim, 3.0)
    nav = sim.devices.vehicle.navigation()
    truth = 3.0 - sim.vehicle.eta[2]
    assert nav.altitude is not None and nav.altitude == pytest.approx(truth, abs=0.05)
    deep = SimBackend(load_scenario("bluerov2_pool", {**over, "vehicle.start_z_m": 2.8}), 0)
    deep.open()
    run(deep, 3.0)  # the transducer 0.1 m under the floor's 0.2 m: inside the 0.3 m blind zone
    assert deep.devices.vehicle.navigation().altitude is None


def test_a_fresh_dvl_altitude_wins_over_the_ping() -> None:
    sim = SimBackend(load_scenario("bluerov2_pool", {"vehicle.actuated": [False] * 6, "ping.noise_std_m": 0.5}), 0)
    sim.open()
    run(sim, 2.0)
    nav = sim.devices.vehicle.navigation()
    assert nav.altitude == sim.dvl.altitude


# ------------------------------------------------------------------ jaw


def test_the_jaw_touches_a_cylinder_where_its_fingers_meet_it(values: dict) -> None:
    """The 20 mm pipe: the half gap at the tool point equals its radius at the contact
    opening; fully open (0.5 rad) the gap is 35.6 mm, too small for a 40 mm pipe."""
    mm = contact_opening_mm(values, 0.010)
    angle = mm * values["jaw.finger_rad_per_mm"]
    assert half_gap_m(angle, values["jaw.hinge_y_m"], values["jaw.tcp_beyond_hinge_m"]) == pytest.approx(0.010)
    assert 2 * half_gap_m(0.5, values["jaw.hinge_y_m"], values["jaw.tcp_beyond_hinge_m"]) == pytest.approx(
        0.0356, abs=2e-4
    )
    assert contact_opening_mm(values, 0.020) == 0.0


def test_the_jaw_holds_the_pipe_with_its_current_and_closes_on_nothing_with_little(values: dict) -> None:
    held, empty = JawModel(values, 0.010), JawModel(values, 0.010)
    for jaw in (held, empty):
        jaw.preshape("parallel")
        for _ in range(600):
            jaw.step(0.01, False)
        assert jaw.motion is GripperMotion.IDLE and jaw.positions[0] == pytest.approx(0.012)
        jaw.close(0.3)
    touched = False
    for _ in range(1500):
        touched |= held.step(0.01, True)
        empty.step(0.01, False)
    assert touched and held.motion is GripperMotion.HOLDING and held.current[0] >= 0.98 * 0.3
    assert held.positions[0] == pytest.approx(contact_opening_mm(values, 0.010) * 1e-3)
    assert empty.motion is GripperMotion.STOPPED and empty.positions[0] == 0.0
    assert empty.current[0] == pytest.approx(values["gripper.idle_current_a"])


def test_the_simulated_jaw_reports_one_motor_group() -> None:
    sim = SimBackend(load_scenario("bluerov2_pool"), 0)
    sim.open()
    state = sim.devices.gripper.state()
    assert state.positions.shape == (1,) and state.currents.shape == (1,)
    with pytest.raises(ValueError, match="known: parallel, small_pipe"):
        sim.devices.gripper.preshape("cylindrical")


# ------------------------------------------------------------------ camera


def test_the_tilted_camera_sees_the_pipe_ahead_and_below() -> None:
    """The survey altitude (1 m) with the pipe 2 m ahead: in the 45 deg tilted camera's
    view and detected; straight below the hull it is out of view."""
    over = {
        "vehicle.actuated": [False] * 6,
        "vehicle.start_x_m": 5.0,
        "vehicle.start_y_m": 4.0,
        "vehicle.start_yaw_rad": 0.0,
        "vehicle.start_z_m": 3.0 - 0.15 - 0.01 - 0.9,
        "pipe.x_m": 7.0,
        "pipe.y_m": 4.0,
    }
    sim = SimBackend(load_scenario("bluerov2_pool", over), 0)
    sim.open()
    run(sim, 2.0)
    assert sim.vision.last_view["in_view"] and sim.devices.detector.latest() is not None
    below = SimBackend(load_scenario("bluerov2_pool", {**over, "pipe.x_m": 5.05}), 0)
    below.open()
    run(below, 2.0)
    assert not below.vision.last_view["in_view"] and below.devices.detector.latest() is None
