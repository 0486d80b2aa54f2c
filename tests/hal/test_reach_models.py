"""The BlueROV2 Heavy + Reach URDFs (kcl/data): they load in the KCL's model with the
frame roles the tasks use, their numbers are the published ones, and the shipped
HAL configs' arm joints and device limits agree with them."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from hal.config import load_hal_config
from hal.joints import joint_mismatch
from kcl.model import DATA_DIR, UvmsModel

ALPHA = DATA_DIR / "bluerov2_heavy_alpha5.urdf"
BRAVO = DATA_DIR / "bluerov2_heavy_bravo7.urdf"
CONFIGS = Path(__file__).resolve().parents[2] / "hal" / "configs"


@pytest.mark.parametrize(
    ("urdf", "joints"),
    [
        (ALPHA, ["alpha_e_base", "alpha_d_shoulder", "alpha_c_elbow", "alpha_b_wrist"]),
        (
            BRAVO,
            [
                "bravo_g_base",
                "bravo_f_shoulder",
                "bravo_e_elbow",
                "bravo_d_elbow_rot",
                "bravo_c_wrist",
                "bravo_b_wrist_rot",
            ],
        ),
    ],
)
def test_models_load_with_the_kcl_roles(urdf: Path, joints: list[str]) -> None:
    model = UvmsModel.load(urdf, frames={"tool": "tool", "stereo_camera": "stereo_camera", "elbow": "elbow"})
    assert list(model.joint_names) == joints and model.n_joints == len(joints)
    assert np.all(model.joint_lower == 0.0) and np.all(model.joint_upper > 3.0)
    q = (model.joint_lower + model.joint_upper) / 2
    for role in ("tool", "stereo_camera", "elbow", "palm_camera"):
        assert model.frame_pose_vehicle(q, role).shape == (4, 4)
    cam = model.frame_pose_vehicle(q, "stereo_camera")
    tilt = np.radians(45.0) if urdf == ALPHA else 0.0  # the Alpha rig's camera looks 45 deg down at its jaw
    forward_down = [np.cos(tilt), 0.0, np.sin(tilt)]
    assert np.allclose(cam[:3, 2], forward_down, atol=1e-6) and np.allclose(cam[:3, 0], [0, 1, 0], atol=1e-6)
    assert np.allclose(cam[:3, 3], [0.21, 0.0, -0.067], atol=1e-9)


def test_alpha_reach_matches_the_published_kinematics() -> None:
    """Spec section 4, derived: D -> C 0.151 m, D -> TCP at most 0.325 m."""
    model = UvmsModel.load(ALPHA)
    rng = np.random.default_rng(3)
    reach = []
    for _ in range(400):
        q = rng.uniform(model.joint_lower, model.joint_upper)
        c, s_ = np.cos(q[0]), np.sin(q[0])
        d_axis = np.array([0.14, 0.0, 0.12 + 0.014]) + np.array([-0.020 * c, -0.020 * s_, 0.033])  # mount, E, D
        elbow = model.frame_pose_vehicle(q, "elbow")[:3, 3]
        tool = model.frame_pose_vehicle(q, "tool")[:3, 3]
        assert np.linalg.norm(elbow - d_axis) == pytest.approx(0.151, abs=0.001)
        reach.append(np.linalg.norm(tool - d_axis))
    assert 0.30 < max(reach) <= 0.3251


def test_shipped_configs_match_their_models() -> None:
    for name, urdf in (("bluerov2_alpha5_serial.yaml", ALPHA), ("bluerov2_bravo7_udp.yaml", BRAVO)):
        cfg = load_hal_config(CONFIGS / name)
        arm = cfg.devices["arm"].params
        names = [j["name"] for j in arm["joints"]]
        assert joint_mismatch(names, list(UvmsModel.load(urdf).joint_names)) is None, name
        assert Path(arm["urdf"]).resolve() == urdf.resolve()
        assert cfg.devices["gripper"].driver == "reach_jaw"
    mixed = load_hal_config(CONFIGS / "bluerov2_alpha5_mixed.yaml")
    assert mixed.devices["arm"].driver == "reach_arm" and mixed.devices["vehicle"].driver == "sim"
