"""Vehicle kinematics and velocity tracking."""

from __future__ import annotations

import math

import numpy as np
import pytest
from simtest_util import PERFECT_TRACKING, run


def test_known_velocities_give_known_poses(make_sim):
    # perfect tracking, no sensors involved: surge 0.2 m/s while turning at 0.1 rad/s
    sim = make_sim(overrides=PERFECT_TRACKING)
    x0, y0, z0, _, _, yaw0 = sim.vehicle.eta.copy()
    u, w, r, T = 0.2, 0.05, 0.1, 10.0
    sim.devices.vehicle.command_body_velocity(np.array([u, 0.0, w, 0.0, 0.0, r]))
    run(sim, T)
    x, y, z, roll, pitch, yaw = sim.vehicle.eta
    # closed form: a circle of radius u/r while sinking at w
    assert yaw == pytest.approx(yaw0 + r * T, abs=1e-9)
    assert x == pytest.approx(x0 + u / r * (math.sin(yaw0 + r * T) - math.sin(yaw0)), abs=1e-4)
    assert y == pytest.approx(y0 - u / r * (math.cos(yaw0 + r * T) - math.cos(yaw0)), abs=1e-4)
    assert z == pytest.approx(z0 + w * T, abs=1e-9)
    assert abs(roll) < 1e-12 and abs(pitch) < 1e-12
    assert sim.ground_truth()["vehicle"]["body_velocity"] == pytest.approx([u, 0, w, 0, 0, r])


def test_lateral_motion_in_a_rotated_body_frame(make_sim):
    sim = make_sim(overrides={**PERFECT_TRACKING, "vehicle.start_yaw_rad": math.pi / 2})
    p0 = sim.vehicle.eta[:3].copy()
    sim.devices.vehicle.command_body_velocity(np.array([0.1, 0.1, 0, 0, 0, 0]))
    run(sim, 5.0)
    # heading east: surge goes east, sway goes south
    assert sim.vehicle.eta[:3] - p0 == pytest.approx([-0.5, 0.5, 0.0], abs=1e-9)


def test_first_order_lag_and_saturation(make_sim):
    over = {**PERFECT_TRACKING, "vehicle.time_constant_s": [0.8, 0.9, 0.6, 0.4, 0.4, 0.6]}
    sim = make_sim(overrides=over)
    sim.devices.vehicle.command_body_velocity(np.array([0.3, 0, 0, 0, 0, 0]))
    run(sim, 0.8)
    assert sim.vehicle.nu[0] == pytest.approx(0.3 * (1 - math.exp(-1)), rel=1e-6)
    sim.devices.vehicle.command_body_velocity(np.array([5.0, 0, 0, 0, 0, 0]))  # beyond max 0.5 m/s
    run(sim, 10.0)
    assert sim.vehicle.nu[0] == pytest.approx(0.5, rel=1e-4)


def test_dead_band_and_poor_tracking_near_zero(make_sim):
    sim = make_sim(overrides={"vehicle.model": "first_order", "vehicle.disturbance_std": [0] * 6})
    p0 = sim.vehicle.eta[:3].copy()
    sim.devices.vehicle.command_body_velocity(np.array([0.008, 0.0, 0.0, 0, 0, 0]))  # inside the 1 cm/s dead band
    run(sim, 5.0)
    assert np.linalg.norm(sim.vehicle.eta[:3] - p0) < 1e-9
    sim.devices.vehicle.command_body_velocity(np.array([0.03, 0.0, 0.0, 0, 0, 0]))
    run(sim, 10.0)
    small_ratio = sim.vehicle.nu[0] / 0.03
    sim.devices.vehicle.command_body_velocity(np.array([0.4, 0.0, 0.0, 0, 0, 0]))
    run(sim, 10.0)
    large_ratio = sim.vehicle.nu[0] / 0.4
    assert 0.5 < small_ratio < 0.85  # near zero the vehicle does much less than asked
    assert large_ratio > 0.99


def test_non_actuated_roll_restores_and_ignores_commands(make_sim):
    sim = make_sim(overrides={**PERFECT_TRACKING, "vehicle.actuated": [True, True, True, False, False, True]})
    assert sim.devices.vehicle.actuated_dofs == (True, True, True, False, False, True)
    sim.devices.vehicle.command_body_velocity(np.array([0, 0, 0, 0.2, 0.2, 0]))
    run(sim, 1.0)
    assert abs(sim.vehicle.eta[3]) < 1e-12 and abs(sim.vehicle.eta[4]) < 1e-12
    sim.vehicle.eta[3] = 0.2  # e.g. knocked over by a wave
    # damped pendulum, period 3 s, damping ratio 0.5 (scenario defaults)
    wn, zeta = 2 * math.pi / 3.0, 0.5
    wd = wn * math.sqrt(1 - zeta**2)
    for _ in range(4):
        run(sim, 0.5)
        t = sim.clock.now() - 1.0
        expected = 0.2 * math.exp(-zeta * wn * t) * (math.cos(wd * t) + zeta * wn / wd * math.sin(wd * t))
        assert sim.vehicle.eta[3] == pytest.approx(expected, abs=0.01)
    run(sim, 10.0)
    assert abs(sim.vehicle.eta[3]) < 0.01


def test_current_drifts_the_vehicle(make_sim):
    sim = make_sim(overrides={**PERFECT_TRACKING, "current.velocity_mps": [0.0, 0.1, 0.0], "current.rejection": 0.7})
    p0 = sim.vehicle.eta[:3].copy()
    run(sim, 10.0)
    assert sim.vehicle.eta[1] - p0[1] == pytest.approx(0.3, abs=1e-6)


def test_disarmed_vehicle_ignores_commands_and_pool_walls_stop_it(make_sim):
    sim = make_sim(overrides=PERFECT_TRACKING)
    veh = sim.devices.vehicle
    veh.disarm()
    p0 = sim.vehicle.eta[:3].copy()
    veh.command_body_velocity(np.array([0.3, 0, 0, 0, 0, 0]))
    run(sim, 2.0)
    assert np.array_equal(sim.vehicle.eta[:3], p0)
    veh.arm()
    veh.command_body_velocity(np.array([0, 0, -0.3, 0, 0, 0]))  # up
    run(sim, 10.0)
    assert sim.vehicle.eta[2] == 0.0  # stopped at the surface
    with pytest.raises(ValueError):
        veh.command_body_velocity(np.zeros(5))
    veh.command_body_velocity(np.array([0.2, 0, 0, 0, 0, 0]))
    run(sim, 1.0)
    veh.command_body_velocity(np.array([np.nan, 0, 0, 0, 0, 0]))  # NaN command: stop, reported
    veh.command_body_velocity(np.array([np.nan, 0, 0, 0, 0, 0]))
    x = sim.vehicle.eta[0]
    run(sim, 1.0)
    assert sim.vehicle.eta[0] == x and np.all(np.isfinite(sim.vehicle.eta))
    events = [e for e in sim.ground_truth()["events"] if e["event"] == "non_finite_command"]
    assert len(events) == 1 and events[0]["device"] == "vehicle"


def test_a_wall_stops_motion_into_it_but_not_along_it(make_sim):
    # heading 45 deg, moving forward into the y wall: the y motion stops at the
    # wall, the x motion (along the wall) goes on; the reported velocity agrees
    sim = make_sim(overrides=PERFECT_TRACKING)
    (x_lo, x_hi), (y_lo, y_hi), _ = sim.vehicle.bounds
    sim.vehicle.eta[:] = [0.5 * (x_lo + x_hi), y_hi - 0.05, 2.0, 0.0, 0.0, math.pi / 4]
    u = 0.2
    sim.devices.vehicle.command_body_velocity(np.array([u, 0, 0, 0, 0, 0]))
    x0 = sim.vehicle.eta[0]
    run(sim, 5.0)
    assert sim.vehicle.eta[1] == y_hi
    assert sim.vehicle.eta[0] - x0 == pytest.approx(u * math.cos(math.pi / 4) * 5.0, abs=0.02)
    nu = sim.ground_truth()["vehicle"]["body_velocity"]
    c, s = math.cos(math.pi / 4), math.sin(math.pi / 4)
    assert s * nu[0] + c * nu[1] == pytest.approx(0.0, abs=1e-12)  # world y velocity
    assert c * nu[0] - s * nu[1] == pytest.approx(u * c, abs=1e-9)  # world x velocity
