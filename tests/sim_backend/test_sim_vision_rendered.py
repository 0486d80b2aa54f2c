"""Vision in the loop: the simulator renders the stereo pair and runs the real detector."""

from __future__ import annotations

import numpy as np
import pytest

import sim_backend
from maris_common.yamlsrc import ConfigError

NEAR = {
    "vehicle.start_x_m": 11.0,
    "vehicle.start_y_m": 6.0,
    "vehicle.start_yaw_rad": 0.0,
    "pipe.x_m": 12.5,
    "pipe.y_m": 6.0,
    "pipe.yaw_rad": 0.3,
}


def _backend(seed: int = 0, **extra: object) -> sim_backend.SimBackend:
    return sim_backend.SimBackend(sim_backend.load_scenario("pool_vision", {**NEAR, **extra}), seed)


#: an exact calibration: the detector's own accuracy, without the run's systematic errors
EXACT = {
    "vision.calib_focal_rel_std": 0.0,
    "vision.calib_principal_px_std": 0.0,
    "vision.calib_stereo_rot_std_rad": 0.0,
    "vision.calib_stereo_trans_std_m": 0.0,
    "vision.mount_rot_std_rad": 0.0,
    "vision.mount_trans_std_m": 0.0,
}


@pytest.mark.slow
def test_detections_come_from_the_rendered_images() -> None:
    b = _backend(**EXACT)
    b.advance(1.0)
    det = b.devices.detector.latest()
    assert det is not None and det.details is not None and det.confidence > 0.6
    view = b.ground_truth()["vision"]
    assert view["detected"] and view["rendered"] and view["position_error_m"] < 0.02 and view["axis_error_rad"] < 0.05
    assert b.clock.now() - det.t >= 0.15 - 1e-9  # published after the scenario's latency
    frames = b.devices.detector.camera_frames()
    assert len(frames) == 1 and frames[0].jpeg[:2] == b"\xff\xd8" and frames[0].width == 320
    assert b.devices.detector.camera_frames() == []  # each frame once


@pytest.mark.slow
def test_same_seed_same_detections() -> None:
    a, b = _backend(5), _backend(5)
    a.advance(0.6)
    b.advance(0.6)
    np.testing.assert_array_equal(a.devices.detector.latest().pose, b.devices.detector.latest().pose)


@pytest.mark.slow
def test_very_turbid_water_gives_no_detection() -> None:
    b = _backend(**{"vision.turbidity": "very_turbid"})
    b.advance(1.0)
    assert b.devices.detector.latest() is None
    assert b.ground_truth()["vision"]["confidence"] == 0.0


@pytest.mark.slow
def test_pipe_out_of_view_is_not_rendered_but_logged_frames_still_are() -> None:
    b = _backend(**{"vehicle.start_yaw_rad": 3.1})  # looking away from the pipe
    b.advance(0.5)
    view = b.ground_truth()["vision"]
    assert not view["rendered"] and "outside both fields of view" in view["reason"]
    assert b.devices.detector.camera_frames()  # the log still gets its frame


def test_unknown_vision_model_is_a_config_error() -> None:
    with pytest.raises(ConfigError, match="vision.model: unknown vision model `rendred`; known: table, rendered"):
        sim_backend.SimBackend(sim_backend.load_scenario("pool_clear", {"vision.model": "rendred"}), 0)
