"""UvmsModel: frames, Jacobians w.r.t. ydot = [qdot; v], manipulability, loading errors."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

from kcl.model import DEFAULT_URDF, UvmsModel
from kcl.rotations import integrate_pose, matrix_to_rpy, pose_matrix, rpy_to_matrix, so3_log
from maris_common.yamlsrc import ConfigError

ROLES = ("tool", "stereo_camera", "palm_camera", "elbow")


@pytest.fixture(scope="module")
def model() -> UvmsModel:
    return UvmsModel.load()


def random_state(model: UvmsModel, rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    q = rng.uniform(model.joint_lower, model.joint_upper)
    eta = np.concatenate([rng.uniform(-5, 5, 3), rng.uniform(-0.6, 0.6, 2), rng.uniform(-3, 3, 1)])
    return q, eta


def step_state(q, eta, ydot, h, l):
    return q + h * ydot[:l], integrate_pose(eta, ydot[l:], h)


def test_default_model_shape(model: UvmsModel) -> None:
    assert model.n_joints == 7 and model.n == 13
    assert len(model.joint_names) == 7
    assert np.all(model.joint_lower < model.joint_upper)
    assert np.all(model.joint_velocity_limit > 0)
    # the arm hangs below the vehicle (FRD: +z), the camera looks forward-down
    T = model.frame_pose_vehicle(np.zeros(7), "tool")
    assert T[2, 3] > 1.0
    Tc = model.frame_pose_vehicle(np.zeros(7), "stereo_camera")
    assert Tc[0, 2] > 0.3 and Tc[2, 2] > 0.3  # optical axis forward and down
    assert Tc[0, 3] > 0.5  # at the front of the hull


def test_world_pose_composes_vehicle_pose(model: UvmsModel) -> None:
    rng = np.random.default_rng(1)
    for _ in range(10):
        q, eta = random_state(model, rng)
        for role in ROLES:
            wT = model.frame_pose_world(q, eta, role)
            np.testing.assert_allclose(wT, pose_matrix(eta) @ model.frame_pose_vehicle(q, role), atol=1e-12)


def test_rpy_roundtrip() -> None:
    rng = np.random.default_rng(2)
    for _ in range(50):
        rpy = np.array([rng.uniform(-3, 3), rng.uniform(-1.5, 1.5), rng.uniform(-3, 3)])
        np.testing.assert_allclose(matrix_to_rpy(rpy_to_matrix(*rpy)), rpy, atol=1e-9)
        R = rpy_to_matrix(*rpy)
        ref = pin.rpy.rpyToMatrix(*rpy)  # independent implementation, same Z-Y-X convention
        np.testing.assert_allclose(R, ref, atol=1e-12)


@pytest.mark.parametrize("role", ROLES)
def test_frame_jacobians_match_finite_differences(model: UvmsModel, role: str) -> None:
    rng = np.random.default_rng(3)
    l, h = model.n_joints, 1e-6
    for _ in range(8):
        q, eta = random_state(model, rng)
        kin = model.kinematics(q, eta)
        J = kin.jacobian_world(role)
        ydot = rng.normal(size=model.n)
        qp, ep = step_state(q, eta, ydot, h, l)
        qm, em = step_state(q, eta, ydot, -h, l)
        Tp, Tm = model.frame_pose_world(qp, ep, role), model.frame_pose_world(qm, em, role)
        lin = (Tp[:3, 3] - Tm[:3, 3]) / (2 * h)
        ang = so3_log(Tp[:3, :3] @ Tm[:3, :3].T) / (2 * h)
        np.testing.assert_allclose(J[:3] @ ydot, lin, atol=1e-6)
        np.testing.assert_allclose(J[3:] @ ydot, ang, atol=1e-6)
        # vehicle axes version is the same velocity seen from the vehicle
        Jv = kin.jacobian_vehicle(role)
        np.testing.assert_allclose(kin.wRv @ Jv[:3], J[:3], atol=1e-12)
        np.testing.assert_allclose(kin.wRv @ Jv[3:], J[3:], atol=1e-12)


def test_matches_analytic_floating_base(model: UvmsModel) -> None:
    """The free-flyer Jacobian (reordered to joints first) equals the floating
    base written out by hand on top of the fixed-base arm Jacobian:
    [[R Ja_lin, R, -R S(p)], [R Ja_ang, 0, R]] with R = wRv, p = vehicle-frame origin."""
    rng = np.random.default_rng(4)
    l = model.n_joints
    fixed = pin.buildModelFromUrdf(str(DEFAULT_URDF))
    data = fixed.createData()
    for _ in range(5):
        q, eta = random_state(model, rng)
        R = rpy_to_matrix(*eta[3:])
        pin.computeJointJacobians(fixed, data, q)
        pin.updateFramePlacements(fixed, data)
        kin = model.kinematics(q, eta)
        for role in ROLES:
            fid = fixed.getFrameId(model.frames[role])
            Ja = pin.getFrameJacobian(fixed, data, fid, pin.ReferenceFrame.LOCAL_WORLD_ALIGNED)
            p = data.oMf[fid].translation
            expected = np.zeros((6, l + 6))
            expected[:3, :l], expected[3:, :l] = R @ Ja[:3], R @ Ja[3:]
            expected[:3, l : l + 3] = R
            expected[:3, l + 3 :] = -R @ pin.skew(p)
            expected[3:, l + 3 :] = R
            np.testing.assert_allclose(kin.jacobian_world(role), expected, atol=1e-10)
            np.testing.assert_allclose(kin.pose_vehicle(role), data.oMf[fid].homogeneous, atol=1e-10)
            np.testing.assert_allclose(kin.arm_jacobian(role), Ja, atol=1e-10)


def test_manipulability_gradient(model: UvmsModel) -> None:
    rng = np.random.default_rng(5)
    h = 1e-6
    for _ in range(10):
        q, _ = random_state(model, rng)
        mu, grad = model.manipulability(q)
        J = model.kinematics(q, np.zeros(6)).arm_jacobian("tool")
        assert mu == pytest.approx(np.sqrt(np.linalg.det(J @ J.T)), rel=1e-9)
        fd = np.array(
            [
                (model.manipulability(q + h * e)[0] - model.manipulability(q - h * e)[0]) / (2 * h)
                for e in np.eye(model.n_joints)
            ]
        )
        np.testing.assert_allclose(grad, fd, atol=1e-7)


def test_unknown_frame_is_config_error() -> None:
    with pytest.raises(ConfigError) as err:
        UvmsModel.load(frames={"tool": "tol"})
    text = str(err.value)
    assert "frames.tool" in text and "`tool`" in text and "r2_uma.urdf:1:1" in text


def test_missing_urdf_is_config_error(tmp_path) -> None:
    with pytest.raises(ConfigError, match="not found"):
        UvmsModel.load(tmp_path / "nope.urdf")
    bad = tmp_path / "bad.urdf"
    bad.write_text("<robot name='x'><link name='a'/></robot>")
    with pytest.raises(ConfigError):
        UvmsModel.load(bad)


def test_snapshot_survives_interleaved_pose_calls(model: UvmsModel) -> None:
    """A simulator may call frame_pose_* on the same model between control steps:
    a Kinematics snapshot still reads its own configuration."""
    rng = np.random.default_rng(6)
    q1, eta1 = random_state(model, rng)
    q2, _ = random_state(model, rng)
    ref = UvmsModel.load().kinematics(q1, eta1)
    kin = model.kinematics(q1, eta1)
    model.frame_pose_vehicle(q2, "tool")
    model.kinematics(q2, eta1).jacobian_world("tool")  # runs the chain on the shared scratch buffers
    for role in ROLES:
        np.testing.assert_allclose(kin.jacobian_world(role), ref.jacobian_world(role), atol=1e-12)
        np.testing.assert_allclose(kin.pose_world(role), ref.pose_world(role), atol=1e-12)
    assert kin.manipulability()[0] == pytest.approx(ref.manipulability()[0])


def _urdf_without(tmp_path, joints: tuple[str, ...]):
    """A copy of the default URDF with some arm joints made fixed."""
    text = DEFAULT_URDF.read_text()
    for j in joints:
        start = text.index(f'<joint name="{j}" type="revolute">')
        text = text[:start] + text[start:].replace('type="revolute"', 'type="fixed"', 1)
    path = tmp_path / "short_arm.urdf"
    path.write_text(text)
    return path


def test_short_arm_model_and_actions(tmp_path) -> None:
    """A user URDF with a 5-joint arm: Jacobians and the mu gradient (J^T J form)
    still match finite differences; the default actions file is rejected with
    the posture lengths named, not a traceback."""
    from kcl.actions import load_actions

    short = UvmsModel.load(_urdf_without(tmp_path, ("j5_forearm_roll", "j7_wrist_roll")))
    assert short.n_joints == 5 and short.n == 11
    rng = np.random.default_rng(12)
    h = 1e-6
    for _ in range(5):
        q = rng.uniform(short.joint_lower, short.joint_upper)
        mu, grad = short.manipulability(q)
        fd = np.array(
            [(short.manipulability(q + h * e)[0] - short.manipulability(q - h * e)[0]) / (2 * h) for e in np.eye(5)]
        )
        np.testing.assert_allclose(grad, fd, atol=1e-7)
    with pytest.raises(ConfigError) as err:
        load_actions(model=short)
    assert "expected 5 entries" in str(err.value) and "postures.survey_folded" in str(err.value)
