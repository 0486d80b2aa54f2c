"""The stereo_pipe_detector role in HAL configs: validation, the field example,
and `maris hal check` listing the cameras."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import cv2
import pytest

from hal.config import load_hal_config
from hal.testing.peers import CAN_GROUP, ROOT, Peer, free_udp_port
from maris_common.yamlsrc import ConfigError
from sim_backend.render_cases import default_calibration, view_case
from vision.calibration import save_stereo_calibration

EDS = ROOT / "hal" / "data" / "cia402_minimal.eds"
CAL = ROOT / "hal" / "data" / "mako_g125_stereo_example.yaml"


def maris(*args: str, timeout: float = 60.0) -> subprocess.CompletedProcess:
    return subprocess.run(
        [sys.executable, "-m", "mission.cli", *args], cwd=ROOT, capture_output=True, text=True, timeout=timeout
    )


def _base(detector: str) -> str:
    return f"""\
devices:
  vehicle: {{driver: ardusub, url: "udpin:127.0.0.1:14550"}}
  arm:
    driver: canopen_arm
    bus: can0
    eds: {EDS}
    joints: [{{name: j1, node_id: 1}}]
  detector:
{detector}
buses:
  can0: {{interface: udp_multicast, channel: "{CAN_GROUP}", port: 45000}}
"""


@pytest.mark.slow
def test_field_example_validates_the_reference_mission() -> None:
    cfg = load_hal_config(ROOT / "hal" / "configs" / "bluerov2_canopen_arm.yaml")
    assert "detector" in cfg.roles and cfg.devices["detector"].driver == "stereo_pipe_detector"
    res = maris("validate", "missions/maris_pipe_recovery.yaml", "--hal", "hal/configs/bluerov2_canopen_arm.yaml")
    assert res.returncode == 0, res.stdout + res.stderr


def test_detector_config_errors_name_the_place(tmp_path: Path) -> None:
    bad_cal = tmp_path / "cal.yaml"
    bad_cal.write_text("%YAML:1.0\n---\nM1: !!opencv-matrix\n   rows: 3\n   cols: 3\n   dt: d\n   data: [ 1., 2. ]\n")
    cfg = tmp_path / "hal.yaml"
    cfg.write_text(
        _base(f"""\
    driver: stereo_pipe_detector
    calibration: {bad_cal}
    left: {{source: frames/left}}
    hsv: {{hue: [22, 300]}}
""")
    )
    with pytest.raises(ConfigError) as exc:
        load_hal_config(cfg)
    msg = str(exc.value)
    assert "cal.yaml:3:1: M1: rows x cols = 3x3 needs 9 numbers" in msg
    assert "hal.yaml:9:5: devices.detector: missing camera: give `left` and `right` (or `side_by_side`)" in msg
    assert "hal.yaml:11:20: devices.detector.left.source: camera source not found" in msg
    assert "devices.detector.hsv.hue: must be [low, high] hues on OpenCV's 0-179 scale" in msg


def test_relative_camera_folders_resolve_against_the_config(tmp_path: Path) -> None:
    (tmp_path / "L").mkdir()
    (tmp_path / "R").mkdir()
    cfg = tmp_path / "hal.yaml"
    cfg.write_text(
        _base(f"""\
    driver: stereo_pipe_detector
    calibration: {CAL}
    left: {{source: L}}
    right: {{source: "rtsp://192.168.2.21/stream"}}
""")
    )
    p = load_hal_config(cfg).devices["detector"].params
    assert p["left"]["source"] == str((tmp_path / "L").resolve()) and p["right"]["source"].startswith("rtsp://")
    assert p["rate_hz"] == 10.0 and p["stale_timeout_s"] == 0.5


JOINTS = (
    "j1_shoulder_yaw",
    "j2_shoulder_pitch",
    "j3_upper_arm_roll",
    "j4_elbow_pitch",
    "j5_forearm_roll",
    "j6_wrist_pitch",
    "j7_wrist_roll",
)  # the shipped URDF's (hal check compares them)


@pytest.fixture
def rig(tmp_path: Path, can_port: int):  # noqa: ANN001, ANN201
    """A field config whose devices are peers (MAVLink, seven CAN drives) and a stereo recording."""
    drives = Peer("hal.testing.cia402_sim", "--channel", CAN_GROUP, "--port", str(can_port), "--nodes", "1,2,3,4,5,6,7")
    calib = default_calibration()
    save_stereo_calibration(calib, tmp_path / "calib.yaml")
    for side in ("L", "R"):
        (tmp_path / side).mkdir()
    for i in range(3):
        c = view_case(1.25, azimuth=1.1, aim_offset_m=0.3, calib=calib, seed=i)
        cv2.imwrite(str(tmp_path / "L" / f"{i}.png"), c.left)
        cv2.imwrite(str(tmp_path / "R" / f"{i}.png"), c.right)
    mav_port = free_udp_port()
    mav = Peer("hal.testing.ardusub_peer", "--url", f"udpout:127.0.0.1:{mav_port}")
    joints = ", ".join(
        f"{{name: {n}, node_id: {i + 1}, counts_per_rad: 1000.0, velocity_units_per_rad_s: 1000.0}}"
        for i, n in enumerate(JOINTS)
    )
    cfg = tmp_path / "field.yaml"
    cfg.write_text(f"""\
buses:
  can0: {{interface: udp_multicast, channel: "{CAN_GROUP}", port: {can_port}}}
devices:
  vehicle: {{driver: ardusub, url: "udpin:127.0.0.1:{mav_port}", heartbeat_timeout: 2.0}}
  arm:
    driver: canopen_arm
    bus: can0
    eds: {EDS}
    joints: [{joints}]
  detector:
    driver: stereo_pipe_detector
    calibration: calib.yaml
    left: {{source: L, fps: 10, loop: true}}
    right: {{source: R, fps: 10, loop: true}}
    sync: sequence
""")
    yield cfg
    mav.stop()
    drives.stop()


@pytest.mark.peer
@pytest.mark.slow
def test_hal_check_lists_the_cameras(rig: Path) -> None:
    res = maris("hal", "check", str(rig), "--wait", "8")
    out = res.stdout
    assert res.returncode == 0 and "all devices healthy" in out, out + res.stderr
    rows = {
        line.split()[0] + " " + line.split()[1]: line for line in out.splitlines() if line.strip().startswith("camera ")
    }
    for cam in ("camera left", "camera right"):  # one row per camera: resolution, frame rate, age of the last frame
        assert " ok " in rows[cam] and "resolution=646x482" in rows[cam] and "frame_age_s=" in rows[cam], out
        assert "fps=" in rows[cam] and "fps=None" not in rows[cam], out
    assert "stereo_pipe_detector" in out and "processing_ms=" in out, out


def test_the_least_reported_confidence_reaches_the_detector_and_is_checked(tmp_path: Path) -> None:
    """``min_reported_confidence`` in the detector's entry becomes the detector's; a value
    outside [0, 1) is refused with the place named."""
    from hal.drivers.pipe_detector import detector_config

    save_stereo_calibration(default_calibration(), tmp_path / "cal.yaml")
    (tmp_path / "L").mkdir()
    (tmp_path / "R").mkdir()
    entry = f"""\
    driver: stereo_pipe_detector
    calibration: {tmp_path / "cal.yaml"}
    left: {{source: L}}
    right: {{source: R}}
    min_reported_confidence: {{value}}
"""
    cfg = tmp_path / "hal.yaml"
    cfg.write_text(_base(entry.replace("{value}", "0.35")))
    params = load_hal_config(cfg).devices["detector"].params
    assert detector_config(params).min_reported_confidence == 0.35
    cfg.write_text(_base(entry.replace("{value}", "1.5")))
    with pytest.raises(ConfigError) as exc:
        load_hal_config(cfg)
    assert "devices.detector.min_reported_confidence: must be within 0 (inclusive) and 1 (exclusive)" in str(exc.value)
