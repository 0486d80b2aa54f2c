"""Detection model: field of view, range, turbidity, occlusion, latency, noise."""

from __future__ import annotations

import math

import numpy as np
import pytest
from simtest_util import PERFECT_TRACKING

from sim_backend.geometry import inverse_pose
from sim_backend.vision import in_field_of_view, occluded, segment_blocks_ray

CAMERA_PITCH = math.radians(50)  # the default URDF's stereo camera looks 50 deg down


def hover_looking_at_pipe(make_sim, overrides=None, seed=0, yaw=0.0):
    """Vehicle still at 1.5 m depth, placed so the grasp point is on the optical axis."""
    sim = make_sim("pool_fixed", seed, {**PERFECT_TRACKING, **(overrides or {})})
    cam = sim.model.frame_pose_vehicle(sim.arm.q, "stereo_camera")
    grasp = sim.pipe_grasp_pose()[:3, 3]
    dz = grasp[2] - (1.5 + cam[2, 3])
    sim.vehicle.eta[:] = [grasp[0] - cam[0, 3] - dz / math.tan(CAMERA_PITCH), grasp[1], 1.5, 0.0, 0.0, yaw]
    return sim, dz / math.sin(CAMERA_PITCH)


def detection_rate(sim, seconds=30.0):
    """Fraction of the images taken from now on that gave a published detection."""
    t_start = sim.clock.now()
    seen, last = 0, None
    for _ in range(int(seconds / 0.01)):
        sim.advance(0.01)
        d = sim.devices.detector.latest()
        if d is not None and d.t != last and d.t > t_start + 1e-9:
            seen += 1
            last = d.t
    images = round((seconds - sim.params["vision.latency_s"]) * sim.params["vision.rate_hz"])
    return seen / images


def test_pure_field_of_view():
    assert in_field_of_view(np.array([0.0, 0.0, 2.0]), 1.0, 0.8)
    assert not in_field_of_view(np.array([0.0, 0.0, -2.0]), 1.0, 0.8)  # behind
    assert in_field_of_view(np.array([math.tan(0.49) * 2, 0.0, 2.0]), 1.0, 0.8)
    assert not in_field_of_view(np.array([math.tan(0.51) * 2, 0.0, 2.0]), 1.0, 0.8)
    assert not in_field_of_view(np.array([0.0, math.tan(0.41) * 2, 2.0]), 1.0, 0.8)


def test_pure_occlusion():
    target = np.array([0.0, 0.0, 3.0])
    link_across = (np.array([-0.5, 0.0, 1.5]), np.array([0.5, 0.0, 1.5]))
    assert segment_blocks_ray(target, *link_across, radius=0.07)
    assert not segment_blocks_ray(target, np.array([-0.5, 0.3, 1.5]), np.array([0.5, 0.3, 1.5]), radius=0.07)
    assert not segment_blocks_ray(target, np.array([-0.5, 0.0, 3.5]), np.array([0.5, 0.0, 3.5]), radius=0.07)  # behind
    assert occluded(target, [np.array([0.0, 1.0, 1.0]), np.array([0.0, -1.0, 1.0])], 0.07)


def test_detection_in_clear_water_is_accurate_and_late(make_sim):
    sim, rng = hover_looking_at_pipe(make_sim)
    assert 2.0 < rng < 4.0
    rate = detection_rate(sim)
    assert 0.88 <= rate <= 1.0  # p = 0.95 per image
    d = sim.devices.detector.latest()
    now = sim.clock.now()
    latency, period = sim.params["vision.latency_s"], 1.0 / sim.params["vision.rate_hz"]
    assert now - period - 1e-9 < d.t + latency <= now + 1e-9  # published latency_s after its image
    truth = inverse_pose(sim.ground_truth_vehicle_pose()) @ sim.pipe_grasp_pose()
    assert np.linalg.norm(d.pose[:3, 3] - truth[:3, 3]) < 0.15  # ~5 cm std at 2.8 m
    assert abs(d.pose[:3, 0] @ truth[:3, 0]) > math.cos(0.1)
    assert 0.5 <= d.confidence <= 1.0
    assert sim.ground_truth()["vision"]["in_view"]


@pytest.mark.parametrize("turbidity, low, high", [("slightly_turbid", 0.38, 0.62), ("very_turbid", 0.0, 0.0)])
def test_turbidity_lowers_detection(make_sim, turbidity, low, high):
    sim, _ = hover_looking_at_pipe(make_sim, {"vision.turbidity": turbidity})
    assert low <= detection_rate(sim) <= high


def test_very_turbid_water_still_detects_up_close(make_sim):
    # inside the 1.2 m visibility: only the low per-image probability remains
    sim, _ = hover_looking_at_pipe(
        make_sim,
        {
            "vision.turbidity": "very_turbid",
            "vision.detection_probability": {"clear": 0.95, "slightly_turbid": 0.5, "very_turbid": 0.3},
        },
    )
    sim.vehicle.eta[2] = 3.9 - 0.25 - 0.9 * math.sin(CAMERA_PITCH)
    sim.vehicle.eta[0] = sim.pipe_grasp_pose()[0, 3] - 0.62 - 0.9 * math.cos(CAMERA_PITCH)
    assert 0.18 <= detection_rate(sim) <= 0.42


def test_outside_field_of_view_or_range_nothing_is_detected(make_sim):
    sim, _ = hover_looking_at_pipe(make_sim, yaw=math.pi / 2)  # camera looks east, pipe is north
    assert detection_rate(sim, 5.0) == 0.0
    d = sim.devices.detector.latest()
    assert d is None or d.t == 0.0  # only the image taken at the start pose, before the turn
    sim, rng = hover_looking_at_pipe(make_sim, {"vision.max_range_m": 2.5})
    assert rng > 2.5
    assert detection_rate(sim, 5.0) == 0.0


def test_occlusion_by_the_arm_lowers_detection(make_sim):
    sim, _ = hover_looking_at_pipe(make_sim)
    view = sim.vision
    # straight line of sight at 2.8 m; an arm link crossing it at 1 m
    target = np.array([0.0, 0.0, 2.8])
    arm = [np.array([-0.3, 0.0, 1.0]), np.array([0.3, 0.0, 1.0])]
    p_free, _ = view.probability(target, [arm[0] + [0, 0.5, 0], arm[1] + [0, 0.5, 0]])
    p_hidden, why = view.probability(target, arm)
    assert why["occluded"] and p_hidden == pytest.approx(p_free * (1 - sim.params["vision.occlusion_factor"]))


def test_the_real_arm_in_front_of_the_camera_hides_the_pipe(make_sim):
    sim, _ = hover_looking_at_pipe(make_sim)
    # swing the shoulder forward: the arm rises into the camera's line of sight
    qdot = np.zeros(sim.model.n_joints)
    qdot[1] = 0.5
    sim.devices.arm.command_joint_velocity(qdot)
    for _ in range(200):
        sim.advance(0.01)
    sim.devices.arm.command_joint_velocity(np.zeros(sim.model.n_joints))
    assert sim.arm.q[1] == pytest.approx(1.0)
    rate = detection_rate(sim, 20.0)
    assert sim.ground_truth()["vision"]["occluded"]
    assert 0.15 <= rate <= 0.42  # 0.95 x (1 - 0.7)


def test_stereo_error_is_largest_along_the_line_of_sight(make_sim):
    sim, rng = hover_looking_at_pipe(make_sim)
    truth = inverse_pose(sim.ground_truth_vehicle_pose()) @ sim.pipe_grasp_pose()  # vehicle is still
    vRc = sim.model.frame_pose_vehicle(sim.arm.q, "stereo_camera")[:3, :3]
    errors, last = [], None
    for _ in range(2000):
        sim.advance(0.01)
        d = sim.devices.detector.latest()
        if d is not None and d.t != last:
            last = d.t
            errors.append(vRc.T @ (d.pose[:3, 3] - truth[:3, 3]))  # camera axes
    std = np.std(np.array(errors), axis=0)
    sigma = sim.params["vision.position_noise_m"]
    assert std[2] == pytest.approx(sigma * rng**2, rel=0.2)
    assert std[0] == pytest.approx(sigma * rng, rel=0.2) and std[1] == pytest.approx(sigma * rng, rel=0.2)


@pytest.mark.slow
def test_the_compiled_image_view_decides_as_probability(make_sim):
    """sim_backend.vision_kernel.image_view against the numpy functions it replaces in
    capture(): the same in-view and occlusion decisions, the range to rounding."""
    from sim_backend.geometry import pose_from_eta, rotation_from_vector
    from sim_backend.vision_kernel import _SAMPLES, N_O, O_IN_VIEW, O_OCCLUDED, O_RANGE, O_TARGET, image_view

    view = make_sim("pool_fixed", 0).vision
    rng = np.random.default_rng(11)
    out = np.zeros(N_O)
    seen = {(True, True): 0, (True, False): 0, (False, False): 0}
    for _ in range(3000):
        wTc = pose_from_eta(np.concatenate((rng.uniform(-2, 2, 3), rng.uniform(-np.pi, np.pi, 3))))
        # the grasp point mostly in front of the camera, arm points near the line of sight
        target_cam = np.array([rng.normal(0, 0.6), rng.normal(0, 0.6), rng.uniform(-0.5, 4.0)])
        g = np.eye(4)
        g[:3, :3] = rotation_from_vector(rng.normal(size=3))
        g[:3, 3] = wTc[:3, :3] @ target_cam + wTc[:3, 3]
        k = int(rng.integers(0, 6))
        arm_cam = target_cam * rng.uniform(0, 1.2, (k, 1)) + rng.normal(0, 0.12, (k, 3))
        arm_w = np.ascontiguousarray(arm_cam @ wTc[:3, :3].T + wTc[:3, 3])
        cTw = inverse_pose(wTc)
        target = cTw[:3, :3].dot(g[:3, 3]) + cTw[:3, 3]
        p, why = view.probability(target, arm_w.dot(cTw[:3, :3].T) + cTw[:3, 3])
        image_view(wTc, g, arm_w, view._view_par, _SAMPLES, out)
        assert (out[O_IN_VIEW] > 0, out[O_OCCLUDED] > 0) == (why["in_view"], why["occluded"])
        assert out[O_RANGE] == pytest.approx(why["range_m"], rel=1e-13, abs=1e-13)
        np.testing.assert_allclose(out[O_TARGET : O_TARGET + 3], target, rtol=0, atol=1e-13)
        seen[(why["in_view"], why["occluded"])] += 1
    assert min(seen.values()) > 50  # every case was met


@pytest.mark.parametrize("calibrated", [False, True])
def test_the_compiled_detection_pose_is_the_numpy_one(make_sim, calibrated):
    """sim_backend.vision_kernel.detection_pose against VisionModel.detection_pose_reference
    (the numpy code it replaces in capture()), exact calibration and with the run's errors:
    the same pose to rounding, for random vehicle, camera and grasp poses and noise draws."""
    from sim_backend.geometry import pose_from_eta, rotation_from_vector
    from sim_backend.vision_kernel import detection_pose

    overrides = (
        {}
        if calibrated
        else {
            k: 0.0
            for k in (
                "vision.calib_focal_rel_std",
                "vision.calib_principal_px_std",
                "vision.calib_stereo_rot_std_rad",
                "vision.calib_stereo_trans_std_m",
                "vision.mount_rot_std_rad",
                "vision.mount_trans_std_m",
            )
        }
    )
    vis = make_sim("pool_clear", 4, overrides).vision
    assert (vis.errors is not None) == calibrated
    rng = np.random.default_rng(5)
    out, work = np.empty((4, 4)), np.zeros((3, 4, 4))
    for _ in range(500):
        wTv = pose_from_eta(
            np.concatenate((rng.uniform(-3, 3, 3), rng.uniform(-0.3, 0.3, 2), rng.uniform(-np.pi, np.pi, 1)))
        )
        vTc = np.eye(4)
        vTc[:3, :3] = rotation_from_vector(rng.normal(0, 0.8, 3))
        vTc[:3, 3] = rng.uniform(-0.4, 0.4, 3)
        wTc = wTv @ vTc
        g = np.eye(4)
        g[:3, :3] = rotation_from_vector(rng.normal(size=3))
        g[:3, 3] = wTc[:3, :3] @ np.array([rng.normal(0, 0.4), rng.normal(0, 0.4), rng.uniform(0.4, 3.0)]) + wTc[:3, 3]
        n = rng.standard_normal(6) * rng.choice([1.0, 1e-12])  # also the tiny-rotation branch of Rodrigues
        r = float(rng.uniform(0.2, 3.0))
        detection_pose(wTv, wTc, g, vis._calib, calibrated, n, vis.pos_noise, vis.ang_noise, r, work, out)
        # the triangulation over a 0.3 m axis span seen from metres away amplifies rounding (~1e-12)
        np.testing.assert_allclose(out, vis.detection_pose_reference(wTv, wTc, g, n, r), rtol=0, atol=1e-10)
