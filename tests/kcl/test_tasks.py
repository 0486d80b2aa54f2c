"""Task library: every task's Jacobian against finite differences of its value,
on random configurations; activations and references behave as documented."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from kcl.model import UvmsModel
from kcl.rotations import integrate_pose, rpy_to_matrix, so3_log
from kcl.tasks import TASK_TYPES, Targets, TaskContext
from kcl.tasks.altitude import VehicleAltitude
from kcl.tasks.arm_velocity_minimization import ArmVelocityMinimization
from kcl.tasks.camera_centering import CameraCentering
from kcl.tasks.horizontal_attitude import VehicleHorizontalAttitude
from kcl.tasks.joint_limits import ArmJointLimits
from kcl.tasks.manipulability import ArmManipulability
from kcl.tasks.occlusion import ElbowCameraOcclusion
from kcl.tasks.preferred_shape import ArmPreferredShape
from kcl.tasks.tool_axis_alignment import ToolAxisAlignment
from kcl.tasks.tool_clearance import ToolClearance
from kcl.tasks.tool_orientation import ToolOrientation
from kcl.tasks.tool_position import ToolPosition
from kcl.tasks.tool_velocity import ToolVelocity
from kcl.tasks.vehicle_geofence import VehicleGeofence
from kcl.tasks.vehicle_pose import VehiclePositionHeading
from kcl.tasks.vehicle_velocity import VehicleVelocity
from kcl.tasks.vehicle_velocity_minimization import VehicleVelocityMinimization

FLOOR_DEPTH = 20.0  # m, flat bottom used to derive the altitude from the pose


@pytest.fixture(scope="module")
def model() -> UvmsModel:
    return UvmsModel.load()


def make_tasks(model: UvmsModel):
    return [
        ArmJointLimits("jl", model),
        ArmManipulability("mu", model, mu_min=0.5, width=0.5),  # always active: Jacobian always computed
        ElbowCameraOcclusion("occ", model, min_distance=5.0),  # always active: Jacobian always computed
        CameraCentering("cam", model),
        ToolPosition("pos", model),
        ToolOrientation("ori", model),
        ToolAxisAlignment("axis", model),
        ArmPreferredShape("shape", model, posture=[0.0, 0.5, None, 1.2, 0.0, None, 0.0]),
        VehicleHorizontalAttitude("att", model),
        VehicleAltitude("alt", model),
        VehiclePositionHeading("wp", model),
        VehicleVelocityMinimization("vstop", model),
        ArmVelocityMinimization("astop", model),
        ToolVelocity("jog", model, in_vehicle_frame=True),
        VehicleVelocity("vjog", model),
        VehicleGeofence("fence", model, margin=0.5, width=3.0),  # active over most of the random poses
        ToolClearance("clear", model, min_clearance=1.0, width=30.0),  # active over all the random poses
    ]


def test_every_registered_task_has_an_example_here(model: UvmsModel) -> None:
    """A new task module needs an example in make_tasks: the checks of this file
    (Jacobian against finite differences, activations, flags) then cover it."""
    assert {t.TYPE for t in make_tasks(model)} == set(TASK_TYPES)


def context(model, q, eta, rng_targets) -> TaskContext:
    goal_R, goal_p, cam_p, veh_goal = rng_targets
    T = np.eye(4)
    T[:3, :3], T[:3, 3] = goal_R, goal_p
    targets = Targets(
        tool_goal=T,
        vehicle_goal=veh_goal,
        camera_target=cam_p,
        tool_velocity=np.r_[veh_goal[:3], cam_p],
        vehicle_velocity=np.r_[cam_p, veh_goal[:3]],
        geofence=np.array([[-4.0, 4.0], [-4.0, 4.0], [4.0, 16.0]]),
    )
    return TaskContext(model.kinematics(q, eta), targets, altitude=FLOOR_DEPTH - eta[2], v=np.zeros(6))


def random_case(model, rng):
    q = rng.uniform(model.joint_lower, model.joint_upper)
    eta = np.concatenate(
        [rng.uniform(-3, 3, 2), rng.uniform(5, 15, 1), rng.uniform(-0.5, 0.5, 2), rng.uniform(-3, 3, 1)]
    )
    goal_R = rpy_to_matrix(*rng.uniform(-1, 1, 3))
    goal_p = eta[:3] + rng.uniform(-1.5, 1.5, 3) + np.array([0, 0, 1.0])
    cam_p = eta[:3] + rng.uniform(-2, 2, 3) + np.array([1.5, 0, 1.0])
    veh_goal = np.concatenate([rng.uniform(-5, 5, 3), rng.uniform(-3, 3, 1)])
    return q, eta, (goal_R, goal_p, cam_p, veh_goal)


def value(task, model, q, eta, targets):
    ctx = context(model, q, eta, targets)
    if isinstance(task, (ToolOrientation, ToolVelocity)):
        return ctx.kin.pose_world("tool")
    return task.evaluate(ctx).x


@pytest.mark.parametrize("index", range(len(TASK_TYPES)))
def test_jacobian_matches_finite_differences(model: UvmsModel, index: int) -> None:
    task = make_tasks(model)[index]
    rng = np.random.default_rng(100 + index)
    l, h = model.n_joints, 1e-6
    checked = 0
    for _ in range(40):
        q, eta, targets = random_case(model, rng)
        out = task.evaluate(context(model, q, eta, targets))
        assert out.J.shape == (task.dim(), model.n)
        assert out.a.shape == out.xdot.shape == out.error.shape == (task.dim(),)
        assert np.all((out.a >= 0) & (out.a <= 1))
        if isinstance(task, (CameraCentering,)) and out.x[0] < 0.05:
            continue  # Jacobian deliberately zeroed at the centred singularity
        ydot = rng.normal(size=model.n)
        qp, ep = q + h * ydot[:l], integrate_pose(eta, ydot[l:], h)
        qm, em = q - h * ydot[:l], integrate_pose(eta, ydot[l:], -h)
        xp, xm = value(task, model, qp, ep, targets), value(task, model, qm, em, targets)
        if isinstance(task, ToolOrientation):
            fd = so3_log(xp[:3, :3] @ xm[:3, :3].T) / (2 * h)
        elif isinstance(task, ToolVelocity):  # "x" is the commanded twist; J maps ydot to the tool's twist
            fd = np.r_[(xp[:3, 3] - xm[:3, 3]) / (2 * h), so3_log(xp[:3, :3] @ xm[:3, :3].T) / (2 * h)]
        elif isinstance(task, (VehicleVelocityMinimization, VehicleVelocity)):
            fd = ydot[l:]  # "x" of a velocity task is the vehicle velocity itself
        elif isinstance(task, ArmVelocityMinimization):
            fd = ydot[:l]
        else:
            fd = (xp - xm) / (2 * h)
        np.testing.assert_allclose(out.J @ ydot, fd, atol=2e-6, rtol=1e-5, err_msg=f"{task.TYPE}")
        checked += 1
        if checked >= 12:
            break
    assert checked >= 8


def test_joint_limit_activation(model: UvmsModel) -> None:
    task = ArmJointLimits("jl", model, margin=0.05, width=0.2, gain=1.0)
    q = model.neutral()
    q[1] = model.joint_upper[1] - 0.05  # at the (shrunk) upper limit
    q[3] = model.joint_lower[3] + 0.05 + 0.1  # halfway into the lower band
    out = task.evaluate(TaskContext(model.kinematics(q, np.zeros(6))))
    assert out.a[1] == pytest.approx(1.0)
    assert out.xdot[1] < 0  # pushed back inside
    assert 0.0 < out.a[3] < 1.0 and out.xdot[3] > 0
    assert out.a[0] == 0.0 and out.xdot[0] == 0.0


def test_reference_rate_saturation(model: UvmsModel) -> None:
    task = ToolPosition("pos", model, gain=10.0, max_rate=0.1)
    q = model.neutral()
    kin = model.kinematics(q, np.zeros(6))
    goal = kin.pose_world("tool").copy()
    goal[:3, 3] += np.array([1.0, 0.5, 0.0])
    out = task.evaluate(TaskContext(kin, Targets(tool_goal=goal)))
    assert np.max(np.abs(out.xdot)) == pytest.approx(0.1)
    np.testing.assert_allclose(out.xdot / np.linalg.norm(out.xdot), out.error / np.linalg.norm(out.error))


def test_tasks_without_targets_are_idle(model: UvmsModel) -> None:
    ctx = TaskContext(model.kinematics(model.neutral(), np.zeros(6)))
    for task in make_tasks(model):
        if isinstance(
            task,
            (
                ToolPosition,
                ToolOrientation,
                CameraCentering,
                ElbowCameraOcclusion,
                VehiclePositionHeading,
                VehicleAltitude,
                ToolVelocity,
                VehicleVelocity,
                VehicleGeofence,
            ),
        ):
            out = task.evaluate(ctx)
            assert np.all(out.a == 0) and out.note


def test_tool_velocity_follows_the_command_in_its_frame_within_its_rates(model: UvmsModel) -> None:
    """The reference is the command in world axes (rotated from vehicle axes when
    asked), scaled as a whole into max_rate / max_angular_rate."""
    eta = np.array([0.0, 0.0, 5.0, 0.1, -0.2, 1.0])
    kin = model.kinematics(model.neutral(), eta)
    twist = np.array([0.05, 0.0, -0.02, 0.0, 0.1, 0.0])
    world = ToolVelocity("jog", model).evaluate(TaskContext(kin, Targets(tool_velocity=twist)))
    np.testing.assert_allclose(world.xdot, twist, atol=1e-15)
    np.testing.assert_allclose(world.J, kin.jacobian_world("tool"), atol=1e-15)
    body = ToolVelocity("jog", model, in_vehicle_frame=True).evaluate(TaskContext(kin, Targets(tool_velocity=twist)))
    np.testing.assert_allclose(body.xdot, np.r_[kin.wRv @ twist[:3], kin.wRv @ twist[3:]], atol=1e-15)
    fast = ToolVelocity("jog", model, max_rate=0.01).evaluate(TaskContext(kin, Targets(tool_velocity=twist)))
    np.testing.assert_allclose(fast.xdot, twist * 0.2, atol=1e-15)  # linear peak 0.05 -> 0.01: direction kept


@settings(max_examples=40, deadline=None)
@given(
    spin=st.floats(-np.pi, np.pi),
    tilt=st.floats(0.05, 1.4),
    flip=st.booleans(),
)
def test_tool_axis_alignment_ignores_the_spin_about_the_axis_and_its_direction(
    model: UvmsModel, spin: float, tilt: float, flip: bool
) -> None:
    """The value is the angle between the tool's x and the goal's x as lines: a goal
    turned about its own x, or with x reversed (a cylinder has no direction), keeps
    it; tilting x away by ``tilt`` gives ``tilt``. The reference drives it down."""
    q = (model.joint_lower + model.joint_upper) / 2
    kin = model.kinematics(q, np.array([0.0, 0.0, 5.0, 0.0, 0.0, 0.3]))
    tool = kin.pose_world("tool")

    def about(axis: np.ndarray, angle: float) -> np.ndarray:
        from kcl.rotations import so3_exp

        return so3_exp(axis / np.linalg.norm(axis) * angle)

    x, y = tool[:3, 0], tool[:3, 1]
    goal = tool.copy()
    goal[:3, :3] = about(y, tilt) @ about(x, spin) @ tool[:3, :3]  # x tilted away by `tilt`, spun about itself
    if flip:
        goal[:3, :3] = about(goal[:3, 2], np.pi) @ goal[:3, :3]  # x and y reversed: the same line
    out = ToolAxisAlignment("axis", model, gain=0.5, max_rate=10.0).evaluate(TaskContext(kin, Targets(tool_goal=goal)))
    assert out.x[0] == pytest.approx(tilt, abs=1e-9)
    assert out.xdot[0] == pytest.approx(-0.5 * tilt, abs=1e-9) and out.a[0] == 1.0
    # the task's rate for a rotation about the common normal closes the angle
    n = np.cross(x, goal[:3, 0] * (-1.0 if flip else 1.0))
    w = n / np.linalg.norm(n)
    v = np.linalg.lstsq(kin.jacobian_world("tool")[3:], w, rcond=None)[0]
    assert (out.J @ v)[0] == pytest.approx(-1.0, abs=1e-6)


def test_preferred_shape_rejects_bad_posture(model: UvmsModel) -> None:
    with pytest.raises(ValueError, match="7 entries"):
        ArmPreferredShape("s", model, posture=[0.0, 1.0])
    with pytest.raises(ValueError, match="limits"):
        ArmPreferredShape("s", model, posture=[9.0] * 7)


def test_uses_arm_flags_match_jacobians(model: UvmsModel) -> None:
    """Tasks that declare they do not use the arm (TPIK 2 skips them) really
    have zero arm columns; likewise for the vehicle columns."""
    rng = np.random.default_rng(9)
    tasks = make_tasks(model) + [CameraCentering("palm", model, camera="palm_camera")]
    assert not CameraCentering("c", model).USES_ARM and tasks[-1].USES_ARM
    for _ in range(5):
        q, eta, targets = random_case(model, rng)
        ctx = context(model, q, eta, targets)
        for task in tasks:
            J = task.evaluate(ctx).J
            if not task.USES_ARM:
                assert not J[:, : model.n_joints].any(), task.TYPE
            if not task.USES_VEHICLE:
                assert not J[:, model.n_joints :].any(), task.TYPE


def test_manipulability_inactive_skips_gradient(model: UvmsModel) -> None:
    task = ArmManipulability("mu", model, mu_min=0.01, width=0.01)
    kin = model.kinematics(np.array([0.0, 0.9, 0.0, 0.6, 0.0, -1.5, 0.0]), np.zeros(6))
    out = task.evaluate(TaskContext(kin))
    assert out.x[0] == pytest.approx(kin.manipulability()[0]) and out.x[0] > 0.02
    assert out.a[0] == 0.0 and not out.J.any()


def test_geofence_pushes_back_from_every_face_and_says_when_it_cannot(model: UvmsModel) -> None:
    task = VehicleGeofence("fence", model, margin=0.5, width=1.0, gain=1.0)
    fence = np.array([[0.0, 25.0], [0.0, 12.0], [0.0, 4.0]])
    inside = TaskContext(model.kinematics(model.neutral(), np.r_[12.0, 6.0, 2.0, 0, 0, 0]), Targets(geofence=fence))
    assert not task.evaluate(inside).a.any()  # well inside: inactive
    eta = np.r_[0.5, 11.5, 3.5, 0.0, 0.0, 0.7]  # on the shrunk north-low, east-high and down-high faces
    out = task.evaluate(TaskContext(model.kinematics(model.neutral(), eta), Targets(geofence=fence)))
    np.testing.assert_allclose(out.a, 1.0)
    assert out.xdot[0] > 0 and out.xdot[1] < 0 and out.xdot[2] < 0  # back inside on every axis
    np.testing.assert_allclose(out.error, [1.0, -1.0, -1.0])
    small = np.array([[0.0, 2.0], [0.0, 12.0], [0.0, 4.0]])
    assert task.evaluate(TaskContext(model.kinematics(model.neutral(), eta), Targets(geofence=small))).note


def test_vehicle_velocity_scales_the_command_as_a_whole(model: UvmsModel) -> None:
    task = VehicleVelocity("vjog", model, max_rate=0.1, max_angular_rate=0.1)
    cmd = np.array([0.2, 0.0, 0.05, 0.0, 0.0, 0.05])
    out = task.evaluate(TaskContext(model.kinematics(model.neutral(), np.zeros(6)), Targets(vehicle_velocity=cmd)))
    np.testing.assert_allclose(out.xdot, cmd * 0.5, atol=1e-15)
    assert not out.J[:, : model.n_joints].any()
