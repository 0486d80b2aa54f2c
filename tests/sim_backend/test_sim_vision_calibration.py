"""Systematic vision errors: stereo calibration (triangulated) and camera mount, per run."""

from __future__ import annotations

import numpy as np
import pytest
from simtest_util import PERFECT_TRACKING

import sim_backend
from maris_common.yamlsrc import ConfigError
from sim_backend.scenario import sample_values
from sim_backend.vision_calibration import CALIBRATION_KEYS, StereoBias, VisionErrors, rig_calibration, run_errors

EXACT = {k: 0.0 for k in CALIBRATION_KEYS}


def _params(**over):
    return sample_values(sim_backend.load_scenario("pool_clear", over), 0)


def _grasp_at(range_m: float) -> np.ndarray:
    T = np.eye(4)
    T[:3, 3] = [0.05, 0.08, range_m]
    T[:3, 0] = [1.0, 0.0, 0.0]
    T[:3, 2] = [0.0, 1.0, 0.0]
    T[:3, 1] = np.cross(T[:3, 2], T[:3, 0])
    return T


def test_zero_errors_mean_an_exact_calibration():
    p = _params(**EXACT)
    assert run_errors(p, 3) is None
    calib = rig_calibration(p)
    sb = StereoBias(calib, calib)
    pts = np.array([[0.1, -0.2, 1.0], [-0.3, 0.1, 2.5]])
    np.testing.assert_allclose(sb.apparent(pts), pts, atol=1e-9)
    assert sb.exact


def test_the_stereo_bias_grows_with_range_and_is_fixed_per_run():
    p = _params()
    errs = [
        [
            float(np.linalg.norm(run_errors(p, s).stereo.apparent_pose(_grasp_at(r))[:3, 3] - _grasp_at(r)[:3, 3]))
            for s in range(40)
        ]
        for r in (1.0, 2.0)
    ]
    near, far = np.median(errs[0]), np.median(errs[1])
    assert 0.001 < near < far  # millimetres at 1 m, more at 2 m (depth error ~ range squared)
    assert far > 2.5 * near
    a, b = run_errors(p, 7), run_errors(p, 7)
    np.testing.assert_array_equal(a.stereo.believed.left.K, b.stereo.believed.left.K)
    np.testing.assert_array_equal(a.mount, b.mount)
    assert not np.array_equal(run_errors(p, 8).mount, a.mount)


def test_the_mount_error_moves_the_reported_pose_rigidly():
    p = _params(**{k: 0.0 for k in CALIBRATION_KEYS if not k.startswith("vision.mount")})
    e = run_errors(p, 2)
    assert isinstance(e, VisionErrors) and e.stereo.exact
    vTc = np.eye(4)
    vTc[:3, 3] = [0.6, 0.0, 0.25]
    cTg = _grasp_at(1.5)
    measured = e.measured_vehicle_pose(vTc, cTg)
    np.testing.assert_allclose(measured, vTc @ e.mount @ cTg, atol=1e-12)
    # the rendered model's correction of a detection made with the URDF's mount is the same move
    np.testing.assert_allclose(e.correct_detection(vTc, vTc @ cTg), measured, atol=1e-12)


def test_the_table_model_reports_the_biased_pose(make_sim):
    quiet = {**PERFECT_TRACKING, "vision.position_noise_m": 0.0, "vision.angle_noise_rad": 0.0}
    exact = make_sim("pool_fixed", 4, {**EXACT, **quiet})
    biased = make_sim(
        "pool_fixed", 4, {**quiet, "vision.calib_principal_px_std": 3.0, "vision.mount_trans_std_m": 0.02}
    )
    assert exact.vision.errors is None and biased.vision.errors is not None
    for sim in (exact, biased):
        sim.vehicle.eta[:] = [11.2, 6.0, 2.5, 0.0, 0.0, 0.0]  # the pipe ahead, below the camera
        for _ in range(100):
            sim.advance(0.01)
    d0, d1 = exact.devices.detector.latest(), biased.devices.detector.latest()
    assert d0 is not None and d1 is not None
    truth = np.linalg.inv(exact.ground_truth_vehicle_pose()) @ exact.pipe_grasp_pose()
    assert np.linalg.norm(d0.pose[:3, 3] - truth[:3, 3]) < 1e-6
    assert np.linalg.norm(d1.pose[:3, 3] - d0.pose[:3, 3]) > 0.005


def test_calibration_parameters_are_validated_with_file_and_line(tmp_path):
    p = tmp_path / "bad_calib.yaml"
    p.write_text(
        "extends: pool_clear\nvision:\n  calib_focal_rel_std: -0.1\n  mount_rot_std_rad: 1.0\ndvl:\n  mount_z_m: 20\n"
    )
    with pytest.raises(ConfigError) as e:
        sim_backend.load_scenario(p)
    text = str(e.value)
    assert f"{p}:3:" in text and "vision.calib_focal_rel_std" in text
    assert f"{p}:4:" in text and "vision.mount_rot_std_rad" in text
    assert f"{p}:6:" in text and "dvl.mount_z_m" in text


def test_dvl_lock_is_judged_at_the_transducers(make_sim):
    # reference point 0.8 m above the floor: in the band there, but the transducers
    # (0.5 m lower) are 0.3 m up, below the Explorer's 0.5 m minimum
    sim = make_sim("pool_fixed", 0, {"dvl.dropout_probability": 0.0})
    sim.vehicle.eta[2] = sim.pool_size[2] - 0.8
    sim.dvl.t = None
    for _ in range(50):
        sim.advance(0.01)
    assert sim.dvl.t is None
    sim.vehicle.eta[2] = sim.pool_size[2] - 1.2
    for _ in range(50):
        sim.advance(0.01)
    truth = sim.pool_size[2] - sim.vehicle.eta[2]  # the hull floats up a little meanwhile
    assert sim.dvl.t is not None and abs(sim.dvl.altitude - truth) < 0.03  # the reference point's altitude
