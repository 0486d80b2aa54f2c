"""The pipe detector on rendered stereo pairs with known truth, and on bad input."""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from sim_backend.render import Scene
from sim_backend.render_cases import view_case
from vision.detector import DetectorConfig, PipeDetector
from vision.errors import VisionInputError
from vision.occlusion import ArmShape, arm_masks
from vision.pipeline import PipePoseEstimator, gravity_in_camera

from .conftest import errors


def test_clear_water_at_working_range(calib, clear_case) -> None:  # noqa: ANN001
    det = PipeDetector(calib).detect(
        clear_case.left,
        clear_case.right,
        gravity_cam=clear_case.gravity_cam,
        vehicle_T_camera=clear_case.vehicle_T_camera,
    )
    pos, ang = errors(det, clear_case)
    assert det.confidence > 0.8 and det.reason == ""
    assert pos < 0.01 and ang < 2.0, (pos, ang)
    assert abs(det.radius_m - 0.05) < 0.003
    # the vehicle frame is the camera frame moved by the mounting
    np.testing.assert_allclose(det.vehicle_T_grasp, clear_case.vehicle_T_camera @ det.cam_T_grasp, atol=1e-12)
    # z along gravity: the frame's roll about the axis comes from the AHRS
    assert det.cam_T_grasp[:3, 2] @ clear_case.gravity_cam > 0.99
    # the visible end is one of the pipe's two ends
    G = clear_case.cam_T_grasp
    ends = [G[:3, 3] + s * 0.5 * G[:3, 0] for s in (-1, 1)]
    assert min(np.linalg.norm(det.end_cam - e) for e in ends) < 0.015


@pytest.mark.parametrize("turbidity", ["clear", "slightly_turbid", "very_turbid"])
def test_bare_pool_is_a_zero_confidence_detection(calib, renderers, turbidity: str) -> None:  # noqa: ANN001
    """No pipe in view: confidence 0 with a reason, never an exception (the
    simulator relies on this to skip frames with the pipe out of view)."""
    pipe_far = np.eye(4)
    pipe_far[:3, 3] = (1.0, 1.0, 3.9)
    det = PipeDetector(calib)
    for k, (x, yaw) in enumerate(((12.0, 0.0), (6.0, 1.2), (18.0, -2.0))):
        pose = np.eye(4)
        c, s = np.cos(yaw), np.sin(yaw)
        pose[:3, :3] = np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]]) @ np.array(
            [[0, -np.sin(0.96), np.cos(0.96)], [1, 0, 0], [0, np.cos(0.96), np.sin(0.96)]]
        )
        pose[:3, 3] = (x, 6.0, 2.5)
        scene = Scene((25.0, 12.0, 4.0), pipe_far, 1.0, 0.05, None, t=0.3 * k)
        left, right = renderers[turbidity].render(scene, pose)
        d = det.detect(left, right)
        assert d.confidence == 0.0 and not d.found and "no pipe" in d.reason


def test_very_turbid_water_hides_the_pipe(calib, renderers) -> None:  # noqa: ANN001
    case = view_case(
        1.25, elevation=0.96, azimuth=1.1, aim_offset_m=0.25, calib=calib, renderer=renderers["very_turbid"]
    )
    assert PipeDetector(calib).detect(case.left, case.right).confidence == 0.0


def test_bad_input_gets_clear_errors(calib, clear_case) -> None:  # noqa: ANN001
    det = PipeDetector(calib)
    L, R = clear_case.left, clear_case.right
    with pytest.raises(VisionInputError, match="left image: missing"):
        det.detect(None, R)
    with pytest.raises(VisionInputError, match="right image: empty or corrupt frame"):
        det.detect(L, np.zeros((0, 0, 3), np.uint8))
    with pytest.raises(VisionInputError, match="expected an 8-bit colour"):
        det.detect(cv2.cvtColor(L, cv2.COLOR_BGR2GRAY), R)
    with pytest.raises(VisionInputError, match="image sizes differ: left 646x482, right 640x482"):
        det.detect(L, R[:, :640].copy())
    with pytest.raises(VisionInputError, match="different aspect ratio"):
        det.detect(L[:400].copy(), R[:400].copy())
    with pytest.raises(ValueError, match="hue bounds"):
        PipeDetector(calib, DetectorConfig(hsv=DetectorConfig().hsv.__class__(hue=(22, 200))))


def test_resized_images_use_the_scaled_calibration(calib, clear_case) -> None:  # noqa: ANN001
    half = [cv2.resize(im, (323, 241), interpolation=cv2.INTER_AREA) for im in (clear_case.left, clear_case.right)]
    det = PipeDetector(calib).detect(*half, gravity_cam=clear_case.gravity_cam)
    pos, ang = errors(det, clear_case)
    assert det.found and pos < 0.03 and ang < 3.0


def test_arm_mask_covers_the_rendered_arm(calib, renderers) -> None:  # noqa: ANN001
    """The reprojection of the arm (kcl.model) covers every pixel the arm takes in
    the rendered images, and with it the pipe behind the arm is still found."""
    from kcl.model import UvmsModel
    from vision.occlusion import arm_points_camera

    model = UvmsModel.load()
    q = np.array([0.0, 0.9, 0.0, 1.2, 0.0, 0.3, 0.0])
    vTc = model.frame_pose_vehicle(q, "stereo_camera")
    eta = np.array([11.15, 6.0, 2.3, 0.0, 0.0, 0.0])
    from kcl.rotations import pose_matrix

    wTv = pose_matrix(eta)
    wTc = wTv @ vTc
    arm_w = np.array([model.frame_pose_world(q, eta, f)[:3, 3] for f in tuple(model.joint_names) + ("tool",)])
    pipe = np.eye(4)  # lying across the line of sight, behind the forearm: it shows in two pieces
    pipe[:3, :3] = np.array([[np.cos(1.0), -np.sin(1.0), 0.0], [np.sin(1.0), np.cos(1.0), 0.0], [0.0, 0.0, 1.0]])
    pipe[:3, 3] = (12.45, 6.0, 3.9)
    rend = renderers["clear"]
    with_arm = rend.render(Scene((25.0, 12.0, 4.0), pipe, 1.0, 0.05, arm_w, 0.07, 0.10), wTc)
    without = rend.render(Scene((25.0, 12.0, 4.0), pipe, 1.0, 0.05, None), wTc)
    shape = ArmShape(link_radius=0.08, hand_radius=0.11, margin_px=2)
    masks = arm_masks(calib, arm_points_camera(model, q), shape)
    for img_a, img_b, mask in zip(with_arm, without, masks):
        arm_px = np.abs(img_a.astype(int) - img_b.astype(int)).max(axis=2) > 40
        assert arm_px.sum() > 500  # the arm is in view
        assert (arm_px & (mask == 0)).sum() <= 0.01 * arm_px.sum()
    est = PipePoseEstimator(calib, DetectorConfig(arm=shape), model)
    det = est.estimate(*with_arm, attitude_rpy=eta[3:], q=q)
    truth = np.linalg.inv(wTc) @ pipe
    assert det.found and det.confidence > 0.6, det.reason
    assert np.linalg.norm(det.cam_T_grasp[:3, 3] - truth[:3, 3]) < 0.01
    g = gravity_in_camera(eta[3:], vTc)
    np.testing.assert_allclose(g, np.linalg.inv(wTc)[:3, :3] @ [0, 0, 1], atol=1e-9)


def test_an_axis_the_other_camera_does_not_see_loses_its_confidence(calib, clear_case) -> None:  # noqa: ANN001
    """The pipe painted out of the right image (inpainted from its surroundings): the left
    camera's two edges alone fix an axis, and the right camera, searched where that cylinder
    projects, shows no edges that agree; the answer stays, at a fifth of the confidence at most,
    and is then too unsure to be reported as the pipe (``min_reported_confidence``)."""
    from vision.detector import UNSEEN_FACTOR, DetectorConfig
    from vision.silhouette import hsv_mask

    det = PipeDetector(calib, DetectorConfig(min_reported_confidence=0.0))  # every answer reported
    both = det.detect(clear_case.left, clear_case.right, gravity_cam=clear_case.gravity_cam)
    pipe = hsv_mask(clear_case.right, det.config.hsv)
    pipe = cv2.dilate(pipe, np.ones((15, 15), np.uint8))
    assert cv2.countNonZero(pipe) > 500
    painted = cv2.inpaint(clear_case.right, pipe, 5, cv2.INPAINT_TELEA)
    one = det.detect(clear_case.left, painted, gravity_cam=clear_case.gravity_cam)
    assert one.quality["views_used"] == "2+0"
    assert "right camera shows no edges" in one.reason
    assert one.confidence <= UNSEEN_FACTOR * both.confidence + 1e-9
    _, ang = errors(one, clear_case)
    assert ang < 3.0
    unreported = PipeDetector(calib).detect(clear_case.left, painted, gravity_cam=clear_case.gravity_cam)
    assert unreported.confidence == 0.0 and not unreported.found and unreported.cam_T_grasp is None
    assert unreported.quality["confidence_unreported"] == one.confidence
    assert "not the pipe" in unreported.reason and "right camera shows no edges" in unreported.reason
