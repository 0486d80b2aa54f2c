"""The BlueROV2 Heavy below the KCL: ArduSub in GUIDED, its vectored 6-DOF mixer, the
T200's bollard curve, and the Reach Alpha 5's reaction on this light hull
(scenario bluerov2_pool, sim_backend/ardusub.py)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from simtest_util import run

from sim_backend import SimBackend, load_scenario
from sim_backend import ardusub_kernel as ak
from sim_backend.ardusub import explicit_geometry, pack_constants
from sim_backend.scenario import sample_values

#: A quiet BlueROV2: no tether tug, the hull's nominal coefficients, equal thrusters.
QUIET = {
    "vehicle.disturbance_force_std": [0] * 6,
    "vehicle.model_uncertainty": 0.0,
    "thrusters.gain_spread": 0.0,
    "vehicle.start_z_m": 1.5,
    "vehicle.start_x_m": 6.0,
    "vehicle.start_y_m": 4.0,
    "vehicle.start_yaw_rad": 0.0,
}


@pytest.fixture(scope="module")
def values() -> dict:
    return sample_values(load_scenario("bluerov2_pool"), 0)


def blue(seed: int = 0, overrides: dict | None = None, scenario: str = "bluerov2_pool") -> SimBackend:
    """The BlueROV2 scenario's simulator (its own URDF: the scenario names it), armed."""
    sim = SimBackend(load_scenario(scenario, overrides), seed)
    sim.open()
    sim.devices.vehicle.arm()
    sim.devices.arm.enable()
    return sim


def wrench(values: dict, inputs: list[float]) -> np.ndarray:
    """Body wrench (6,) of the mixer's steady output for ``inputs`` (roll, pitch, yaw,
    throttle up, forward, lateral), through the ESCs and the bollard table."""
    a = pack_constants(values)
    out = np.zeros(8)
    ak.mix_vectored_6dof(np.array(inputs, dtype=float), a, out)
    pwm = np.clip(1500.0 + 400.0 * out, 1100.0, 1900.0)
    thrust = np.array([ak.thrust_of_pwm(p, a) for p in pwm])
    return explicit_geometry(values["thrusters.positions_m"], values["thrusters.directions"]) @ thrust


@pytest.mark.parametrize(
    ("axis", "dof", "sign"),
    [(0, 3, 1.0), (1, 4, 1.0), (2, 5, 1.0), (3, 2, -1.0), (4, 0, 1.0), (5, 1, 1.0)],
)
def test_each_input_of_the_mixer_moves_its_axis_the_right_way(values: dict, axis: int, dof: int, sign: float) -> None:
    """ArduSub's factors with the thrusters' force directions: roll right rolls starboard
    down, pitch up lifts the nose, yaw right turns clockwise, throttle up pushes up (-z),
    forward forward, lateral to starboard; that axis carries the largest share."""
    inputs = [0.0] * 6
    inputs[axis] = 0.4
    w = wrench(values, inputs)
    assert sign * w[dof] > 0.0
    forces, torques = np.abs(w[:3]), np.abs(w[3:])
    if dof < 3:
        assert forces[dof] == forces.max()
    else:
        assert torques[dof - 3] == torques.max()


def test_forward_thrust_below_the_centre_of_gravity_pitches_the_nose_up(values: dict) -> None:
    """The horizontal thrusters sit 8.5 cm below the centre of gravity: full forward
    gives ~129 N of surge and ~11 N m of pitch (nose up), which the attitude loop fights."""
    w = wrench(values, [0, 0, 0, 0, 1.0, 0])
    assert w[0] == pytest.approx(0.7071 * 2 * (51.5 + 39.9), rel=1e-3)
    assert w[4] == pytest.approx(0.085 * w[0], rel=1e-3)
    assert abs(w[1]) < 1e-9 and abs(w[5]) < 1e-9


def test_a_saturated_group_is_scaled_as_a_whole(values: dict) -> None:
    """Yaw and forward at full stick: the horizontal group's outputs would reach 2; the
    mixer divides the group by its largest output (direction kept, no priority)."""
    a = pack_constants(values)
    out = np.zeros(8)
    ak.mix_vectored_6dof(np.array([0, 0, 1.0, 0, 1.0, 0]), a, out)
    raw = np.array([1 * 1 - 1, -1 - 1, -1 + 1, 1 + 1], dtype=float)  # yaw*Y + forward*F per motor 1-4
    np.testing.assert_allclose(out[:4], raw / np.abs(raw).max())
    np.testing.assert_allclose(out[4:], 0.0)


def test_the_thrust_table_passes_through_the_bollard_points_and_keeps_its_dead_band(values: dict) -> None:
    a = pack_constants(values)
    for pwm, thrust in zip(values["thrusters.table_pwm_us"], values["thrusters.table_thrust_n"]):
        assert ak.thrust_of_pwm(pwm, a) == pytest.approx(thrust, abs=1e-9)
    grid = np.linspace(1100.0, 1900.0, 801)
    thrusts = np.array([ak.thrust_of_pwm(p, a) for p in grid])
    assert np.all(np.diff(thrusts) >= -1e-12)  # monotone
    assert np.all(thrusts[(grid >= 1472) & (grid <= 1528)] == 0.0)


def test_ardusub_follows_surge_and_yaw_references_and_holds_depth_and_level() -> None:
    sim = blue(0, QUIET)
    veh = sim.devices.vehicle
    veh.command_body_velocity(np.array([0.2, 0, 0, 0, 0, 0]))
    z0 = sim.vehicle.eta[2]
    run(sim, 30.0)
    assert sim.vehicle.nu[0] == pytest.approx(0.2, abs=0.03)
    assert abs(sim.vehicle.eta[2] - z0) < 0.05
    assert abs(sim.vehicle.eta[3]) < 0.03 and abs(sim.vehicle.eta[4]) < 0.05
    veh.command_body_velocity(np.array([0, 0, 0, 0, 0, 0.2]))
    run(sim, 10.0)
    assert sim.vehicle.nu[5] == pytest.approx(0.2, abs=0.05)
    veh.command_body_velocity(np.array([0, 0, 0.2, 0, 0, 0]))
    z1 = sim.vehicle.eta[2]
    run(sim, 5.0)
    assert sim.vehicle.eta[2] - z1 == pytest.approx(0.2 * 5.0, rel=0.25)  # the depth target moves at 0.2 m/s
    assert np.isfinite(sim.vehicle.S).all()


def test_every_output_passes_through_the_esc_range_and_the_table() -> None:
    sim = blue(1)
    sim.devices.vehicle.command_body_velocity(np.array([0.5, -0.5, 0.5, 0, 0, 0.3]))
    run(sim, 3.0)
    out = sim.vehicle.motor_outputs
    assert out is not None and np.all(np.abs(out) <= 1.0) and np.abs(out).max() > 0.5
    assert np.all(sim.vehicle.thrust <= 51.5 * 1.06) and np.all(sim.vehicle.thrust >= -39.9 * 1.06)


def test_shipped_velocity_gains_wander_where_the_tuned_ones_hold() -> None:
    """Held on a point by an outer position loop (what the KCL's waypoint task does:
    0.3/s on the navigation's position error, references at 10 Hz) against the
    tether's tug: ArduSub's default PSC_VELXY (the T200 dead band swallows its P term)
    lets the vehicle wander about twice as far (RMS) as the scenario's tuned gains
    (the reason docs/bluerov2.md gives for tuning them): seeds 0-5 give RMS 0.10-0.15 m
    tuned, 0.23-0.44 m with the defaults."""
    wander = {}
    for scenario in ("bluerov2_pool", "bluerov2_pool_ardusub_defaults"):
        sim = blue(3, {"vehicle.start_z_m": 1.5, "vehicle.start_x_m": 6.0, "vehicle.start_y_m": 4.0}, scenario)
        veh = sim.devices.vehicle
        target = sim.vehicle.eta[:3].copy()
        off = []
        for k in range(900):  # 90 s at 10 Hz
            nav = veh.navigation()
            yaw = float(nav.attitude[2])
            err = target - np.asarray(nav.position)
            c, s_ = math.cos(yaw), math.sin(yaw)
            body = np.array([c * err[0] + s_ * err[1], -s_ * err[0] + c * err[1], err[2]])
            veh.command_body_velocity(np.r_[np.clip(0.3 * body, -0.25, 0.25), 0.0, 0.0, 0.0])
            run(sim, 0.1)
            if k >= 300:  # after 30 s of settling
                off.append(float(np.linalg.norm(sim.vehicle.eta[:2] - target[:2])))
        wander[scenario] = float(np.sqrt(np.mean(np.square(off))))
    assert wander["bluerov2_pool"] < 0.2, wander
    assert wander["bluerov2_pool_ardusub_defaults"] > 1.5 * wander["bluerov2_pool"], wander


def test_a_moving_alpha_visibly_disturbs_the_light_hull_and_stays_bounded() -> None:
    """Thrusters off, water still: the Alpha's base rotation and shoulder swinging at
    their speed limits turn the 13.5 kg hull by a measurable amount (its links are
    ~1.4 kg against R2's hull of 420 kg); nothing grows without bound."""
    off = {**QUIET, "vehicle.actuated": [False] * 6, "vehicle.net_buoyancy_n": 0.0}
    sim = blue(0, off)
    still = blue(0, {**off, "arm.coupling": False})
    yaw, nu_peak = [], 0.0
    for k in range(400):
        t = 0.01 * k
        qdot = np.array([0.5 * math.cos(2.0 * t), 0.5 * math.sin(2.0 * t), 0.0, 0.0])
        for s in (sim, still):
            s.devices.arm.command_joint_velocity(qdot)
            s.advance(0.01)
        yaw.append(sim.vehicle.eta[5])
        nu_peak = max(nu_peak, float(np.abs(sim.vehicle.nu[3:]).max()))
    assert max(yaw) - min(yaw) > 0.01  # the hull turns under the arm (rad)
    assert nu_peak > 0.01  # rad/s
    assert np.abs(still.vehicle.nu[3:]).max() < 1e-9  # without the coupling nothing moves it
    assert np.isfinite(sim.vehicle.S).all() and nu_peak < 1.0


def test_the_autopilot_holds_the_hull_against_the_moving_alpha() -> None:
    """The same swinging arm with ArduSub on: roll and pitch stay within a few degrees
    (its attitude loops, T200 dead band included); the heading, held by the weak yaw
    loop, still swings visibly (~0.1 rad) and stays within 0.2 rad."""
    sim = blue(0, QUIET)
    yaw0 = sim.vehicle.eta[5]
    peak = np.zeros(3)
    for k in range(1000):
        t = 0.01 * k
        sim.devices.vehicle.command_body_velocity(np.zeros(6))
        sim.devices.arm.command_joint_velocity(np.array([0.5 * math.cos(1.0 * t), 0.5 * math.sin(1.0 * t), 0, 0]))
        sim.advance(0.01)
        att = np.array([sim.vehicle.eta[3], sim.vehicle.eta[4], sim.vehicle.eta[5] - yaw0])
        peak = np.maximum(peak, np.abs(att))
    assert peak[0] < 0.05 and peak[1] < 0.05
    assert 0.02 < peak[2] < 0.2
    assert np.isfinite(sim.vehicle.S).all()


def test_the_scenario_names_its_rig_and_the_simulator_loads_it() -> None:
    sim = SimBackend(load_scenario("bluerov2_pool"), 0)
    assert list(sim.model.joint_names) == ["alpha_e_base", "alpha_d_shoulder", "alpha_c_elbow", "alpha_b_wrist"]
    assert sim.devices.gripper.preshapes == ("parallel", "small_pipe")


def test_a_missing_rig_file_names_the_scenario_line(tmp_path) -> None:
    from maris_common.yamlsrc import ConfigError
    from sim_backend.platform import scenario_file

    path = tmp_path / "rig.yaml"
    path.write_text("extends: bluerov2_pool\nplatform:\n  model: no_such_arm.urdf\n")
    with pytest.raises(ConfigError) as exc:
        scenario_file(load_scenario(path), "model")
    assert f"{path}:3:10" in str(exc.value) and "no_such_arm.urdf" in str(exc.value)


def test_ardusub_guided_needs_a_dvl_and_the_frame() -> None:
    from maris_common.yamlsrc import ConfigError

    with pytest.raises(ConfigError, match="GUIDED without a position estimate"):
        load_scenario("bluerov2_pool", {"dvl.present": False})
    with pytest.raises(ConfigError, match="needs the frame"):
        load_scenario("bluerov2_pool", {"ardusub.motor_factors": None})
