"""The simulator's fast paths give the numbers of the code they replace, bit for bit:
readings built without the dataclasses' generated __init__ (sim_backend.devices._reading),
geometry.norm for np.linalg.norm, ndarray.dot for the @ of small poses and points."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from hal.interfaces import Health, HealthState, JointState, NavigationState
from sim_backend.devices import _health, _reading


def test_readings_are_plain_field_holders() -> None:
    for cls in (NavigationState, JointState, Health):
        fields = {f.name: None for f in dataclasses.fields(cls)}
        assert vars(cls(**fields)) == fields  # the generated __init__ stores the fields, nothing else
        assert not hasattr(cls, "__post_init__") and not hasattr(cls, "__slots__")


def test_fast_health_equals_the_constructed_one() -> None:
    assert _health(HealthState.OK, 1.0) == Health(HealthState.OK, 1.0)
    assert _health(HealthState.FAULT, 2.0, "x", {"a": 1}) == Health(HealthState.FAULT, 2.0, "x", {"a": 1})
    assert _health(HealthState.OK, 1.0).info is not _health(HealthState.OK, 1.0).info


def test_fast_reading_equals_the_constructed_one() -> None:
    a = np.arange(3.0)
    fields = dict(t=1.5, position=a, attitude=a + 1, body_velocity=None, velocity_t=None, depth=2.0, altitude=0.8)
    fast, slow = _reading(NavigationState, **fields), NavigationState(**fields)
    assert type(fast) is NavigationState
    assert dataclasses.asdict(fast).keys() == dataclasses.asdict(slow).keys()
    assert repr(fast) == repr(slow)
    try:
        fast.t = 2.0  # type: ignore[misc]
    except dataclasses.FrozenInstanceError:
        pass
    else:
        raise AssertionError("a fast reading must stay frozen")


def test_navigation_and_joint_readings_are_fresh_arrays(make_sim) -> None:
    sim = make_sim("pool_fixed", 3)
    sim.advance(0.5)
    nav, js = sim.devices.vehicle.navigation(), sim.devices.arm.joint_state()
    np.testing.assert_array_equal(nav.attitude, sim.ahrs.attitude)
    np.testing.assert_array_equal(nav.position, sim.ahrs.position)
    np.testing.assert_array_equal(nav.body_velocity, np.concatenate((sim.dvl.velocity, sim.ahrs.rates)))
    assert sim.devices.vehicle.navigation() is nav  # one reading per simulated instant
    sim.advance(0.01)
    nav2 = sim.devices.vehicle.navigation()
    assert not np.shares_memory(nav2.position, sim.ahrs.position) and not np.shares_memory(nav.attitude, nav2.attitude)
    assert not np.shares_memory(js.position, sim.devices.arm.joint_state().position)


def test_norm_is_numpys_bit_for_bit() -> None:
    from sim_backend.geometry import norm

    rng = np.random.default_rng(3)
    for _ in range(2000):
        m = rng.normal(0.0, 10.0 ** rng.integers(-6, 4), (4, 4))
        for v in (m[:3, 3], m[:3, 0], m[1], m[:, 2], m[0, :3] - m[1, :3]):  # contiguous and strided views
            assert norm(v) == float(np.linalg.norm(v))


@pytest.mark.slow
def test_dot_is_matmul_bit_for_bit_on_poses_and_points() -> None:
    rng = np.random.default_rng(5)
    for _ in range(3000):
        A, B = rng.normal(size=(4, 4)), rng.normal(size=(4, 4))
        P, v = rng.normal(size=(8, 3)), rng.normal(size=3)
        R = A[:3, :3]  # a strided view, as the pose blocks are
        for x, y in ((A, B), (R, B[:3, 3]), (P, R.T), (R.T, B[:3, :3]), (-R.T, v), (P, v), (v, B[:3, 0]), (R, R)):
            np.testing.assert_array_equal(x.dot(y), x @ y)


def test_pose_from_eta_is_the_kcls_pose_matrix() -> None:
    from kcl.rotations import pose_matrix
    from sim_backend.geometry import pose_from_eta

    rng = np.random.default_rng(9)
    for _ in range(500):
        eta = rng.normal(0.0, 3.0, 6)
        np.testing.assert_array_equal(pose_from_eta(eta), pose_matrix(eta))


def test_image_time_placements_follow_the_joints(make_sim) -> None:
    import pinocchio as pin

    sim = make_sim("pool_fixed", 2)
    sim.devices.arm.command_joint_velocity(np.full(sim.arm.n, 0.2))
    sim.advance(0.3)
    pin.forwardKinematics(sim._fk_model, sim._fk_data, sim.arm.q)
    pin.updateFramePlacements(sim._fk_model, sim._fk_data)
    for i, M in zip(sim._arm_point_ids, sim._arm_point_placements):
        np.testing.assert_array_equal(M.translation, sim._fk_data.oMf[i].translation)
    np.testing.assert_array_equal(sim._camera_placement.homogeneous, sim._fk_data.oMf[sim._camera_id].homogeneous)
