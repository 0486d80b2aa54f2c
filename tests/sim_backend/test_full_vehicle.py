"""The full vehicle model: thrusters and allocation, DCL, rigid body, arm coupling, gyro."""

from __future__ import annotations

import math

import numpy as np
import pytest
from simtest_util import run

from sim_backend.thrusters import allocate, command_for_thrust, geometry, speed_for_command, thrust_for_speed

B = geometry(math.pi / 4, 0.5, 0.35, 0.45, 0.3)
BINV = np.ascontiguousarray(np.linalg.pinv(B))

#: A quiet hull: no disturbance, no model error, no thruster spread.
QUIET = {
    "vehicle.disturbance_force_std": [0] * 6,
    "vehicle.model_uncertainty": 0.0,
    "thrusters.gain_spread": 0.0,
    "ahrs.vibration_rad_s": 0.0,
}


def test_allocation_reproduces_feasible_wrenches():
    tau = np.array([40.0, -20.0, 30.0, 5.0, -8.0, 6.0])
    out = np.zeros(8)
    allocate(tau, BINV, 100.0, 70.0, out)
    assert B @ out == pytest.approx(tau, abs=1e-9)


def test_allocation_serves_torque_first_and_keeps_force_direction():
    # a yaw torque and a surge/sway demand far beyond what 4 horizontal thrusters give
    tau = np.array([600.0, 300.0, 0.0, 0.0, 0.0, 20.0])
    out = np.zeros(8)
    allocate(tau, BINV, 100.0, 70.0, out)
    got = B @ out
    assert got[5] == pytest.approx(20.0, abs=1e-9)  # the torque is served in full
    assert got[1] / got[0] == pytest.approx(0.5, rel=1e-9)  # surge/sway scaled together
    assert got[0] < 600.0
    assert np.all(out <= 100.0 + 1e-9) and np.all(out >= -70.0 - 1e-9)
    assert np.isclose(out[:4], 100.0).any() or np.isclose(out[:4], -70.0).any()  # a thruster at its limit
    # a torque that alone saturates (symmetric limits) is scaled down, nothing left for the force
    tau = np.array([50.0, 0.0, 0.0, 0.0, 0.0, 500.0])
    allocate(tau, BINV, 70.0, 70.0, out)
    got = B @ out
    assert got[0] == pytest.approx(0.0, abs=1e-9) and 0 < got[5] < 500.0


def test_thrust_curve_dead_zone_and_inverse():
    # the DCL's nominal inverse without the dead zone: small demands fall short
    for T in (1.0, 5.0, 50.0, -20.0):
        n = speed_for_command(command_for_thrust(T, 100.0, 70.0), 0.0)
        assert thrust_for_speed(n, 1.0, 100.0, 70.0) == pytest.approx(T)
    small = thrust_for_speed(speed_for_command(command_for_thrust(1.0, 100.0, 70.0), 0.08), 1.0, 100.0, 70.0)
    assert 0.0 < small < 0.1  # 1 N asked, under 0.1 N delivered
    assert thrust_for_speed(speed_for_command(0.05, 0.08), 1.0, 100.0, 70.0) == 0.0
    big = thrust_for_speed(speed_for_command(command_for_thrust(80.0, 100.0, 70.0), 0.08), 1.0, 100.0, 70.0)
    assert 60.0 < big < 80.0


def test_dcl_tracks_with_the_dvl_and_drifts_unseen_without(make_sim):
    # a steady push (umbilical tug) the model does not know: the DVL loop rejects it,
    # the model-only loop cannot see it and the vehicle drifts while its navigation
    # believes it holds still
    push = {**QUIET, "current.velocity_mps": [0.0, 0.03, 0.0]}
    ok = make_sim("pool_fixed", 0, push)
    blind = make_sim("pool_fixed", 0, {**push, "dvl.present": False})
    for sim in (ok, blind):
        run(sim, 40.0)
    assert abs(ok.vehicle.nu[1]) < 0.01
    assert blind.vehicle.nu[1] == pytest.approx(0.03, abs=0.01)  # carried by the water
    drift_truth = blind.vehicle.eta[1] - 6.0
    drift_nav = blind.ahrs.position[1] - 6.0
    assert drift_truth > 0.5 and abs(drift_nav) < 0.1


def test_commanded_speed_is_reached_with_the_dvl_not_without(make_sim):
    ok = make_sim("pool_fixed", 0, QUIET)
    blind = make_sim("pool_fixed", 0, {**QUIET, "dvl.present": False})
    for sim in (ok, blind):
        sim.devices.vehicle.command_body_velocity(np.array([0.1, 0, 0, 0, 0, 0]))
        run(sim, 20.0)
    assert ok.vehicle.nu[0] == pytest.approx(0.1, abs=0.01)
    # the dead zone and the nominal thrust curve leave the model-only loop short near zero
    assert blind.vehicle.nu[0] < 0.08
    assert blind.vehicle.velocity_estimate[0] == pytest.approx(0.1, abs=0.01)  # ... while it believes 0.1


def test_free_floating_momentum_is_conserved_when_the_arm_moves(make_sim):
    # thrusters off, no water forces: what the arm's links gain, the vehicle loses
    free = {
        **QUIET,
        "vehicle.actuated": [False] * 6,
        "vehicle.linear_damping": [0] * 6,
        "vehicle.quadratic_damping": [0] * 6,
        "vehicle.metacentric_height_m": 0.0,
        "vehicle.net_buoyancy_n": 0.0,
        "vehicle.start_z_m": 2.0,
    }
    sim = make_sim("pool_fixed", 0, free)
    cp = sim.vehicle.coupling
    n = sim.arm.n
    sim.devices.arm.command_joint_velocity(0.3 * np.cos(np.arange(n)))
    for _ in range(20):
        sim.advance(0.01)
    Mbb = cp.base_inertia(sim.arm.q)
    Mbb = np.triu(Mbb) + np.triu(Mbb, 1).T + np.diag(sim.vehicle.hull.added)
    p = Mbb @ sim.vehicle.nu + cp.arm_momentum(sim.arm.q, sim.arm.qdot)
    assert np.abs(sim.vehicle.nu).max() > 1e-3  # the vehicle did move
    assert np.abs(p).max() < 0.02 * np.abs(cp.arm_momentum(sim.arm.q, sim.arm.qdot)).max()
    # without coupling the vehicle does not feel the arm
    still = make_sim("pool_fixed", 0, {**free, "arm.coupling": False})
    still.devices.arm.command_joint_velocity(0.3 * np.cos(np.arange(n)))
    for _ in range(20):
        still.advance(0.01)
    assert np.abs(still.vehicle.nu).max() < 1e-9


def test_free_roll_period_follows_the_metacentric_height(make_sim):
    over = {
        **QUIET,
        "vehicle.actuated": [True, True, True, False, False, True],
        "vehicle.linear_damping": [0] * 6,
        "vehicle.quadratic_damping": [0] * 6,
        "arm.coupling": False,
    }
    sim = make_sim("pool_fixed", 0, over)
    sim.vehicle.eta[3] = 0.05
    rolls = []
    for _ in range(600):
        sim.advance(0.01)
        rolls.append(sim.vehicle.eta[3])
    crossings = [i for i in range(1, len(rolls)) if rolls[i - 1] > 0 >= rolls[i]]
    period = (crossings[1] - crossings[0]) * 0.01
    from sim_backend.hydrodynamics import roll_period

    assert period == pytest.approx(roll_period(sim.vehicle.hull), rel=0.03)
    assert 2.0 < period < 4.0


def test_gyro_noise_has_a_vibration_line_that_follows_thrust(make_sim):
    loud = {**QUIET, "ahrs.vibration_rad_s": 0.05, "ahrs.rate_noise_std_rad_s": 0.001, "vehicle.start_z_m": 2.0}
    sim = make_sim("pool_fixed", 1, loud)
    sim.devices.vehicle.command_body_velocity(np.array([0.4, 0, 0, 0, 0, 0]))
    run(sim, 5.0)
    rates = []
    for _ in range(1024):
        sim.advance(0.01)
        rates.append(sim.ahrs.rates[2] - sim.vehicle.nu[5])
    spec = np.abs(np.fft.rfft(np.array(rates) - np.mean(rates)))
    freqs = np.fft.rfftfreq(len(rates), 0.01)
    assert abs(freqs[np.argmax(spec)] - sim.params["ahrs.vibration_hz"]) < 0.3
    assert sim.vehicle.vibration_level > 0.2


def test_a_silent_dvl_is_dropped_not_held(make_sim):
    # the DCL must not brake for ever against the last ping it got: after the DVL
    # falls silent it goes on with its model estimate and the vehicle stops
    sim = make_sim("pool_fixed", 0, QUIET)
    sim.devices.vehicle.command_body_velocity(np.array([0.25, 0, 0, 0, 0, 0]))
    run(sim, 10.0)
    sim.inject("dvl_dropout")
    sim.devices.vehicle.command_body_velocity(np.zeros(6))
    run(sim, 15.0)
    assert abs(sim.vehicle.nu[0]) < 0.05
