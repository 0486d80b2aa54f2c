"""Calibration files (OpenCV FileStorage YAML/JSON, ROS camera_info) and rectification."""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np
import pytest
import yaml

from maris_common.yamlsrc import ConfigError
from vision.calibration import ideal_stereo, load_stereo_calibration, save_stereo_calibration, undistort_points
from vision.errors import VisionInputError
from vision.rectify import rectify_calibration

RIG = ideal_stereo(
    640, 480, 1.0, 0.15, distortion=(-0.1, 0.03, 0.001, -0.0005, 0.0), right_rotation_rpy=(0.01, -0.02, 0.005)
)


def same(a, b) -> None:  # noqa: ANN001
    for ca, cb in ((a.left, b.left), (a.right, b.right)):
        assert ca.size == cb.size
        np.testing.assert_allclose(ca.K, cb.K, atol=1e-9)
        np.testing.assert_allclose(ca.D, cb.D, atol=1e-12)
    np.testing.assert_allclose(a.R, b.R, atol=1e-9)
    np.testing.assert_allclose(a.T, b.T, atol=1e-12)


@pytest.mark.parametrize("suffix", [".yaml", ".json"])
def test_opencv_filestorage_round_trip(tmp_path: Path, suffix: str) -> None:
    path = save_stereo_calibration(RIG, tmp_path / f"stereo{suffix}")
    same(load_stereo_calibration(path), RIG)
    fs = cv2.FileStorage(str(path), cv2.FILE_STORAGE_READ)  # OpenCV itself reads what we wrote
    assert fs.getNode("M1").mat().shape == (3, 3) and int(fs.getNode("image_width").real()) == 640
    fs.release()


def test_opencv_intrinsics_plus_extrinsics_files(tmp_path: Path) -> None:
    fs = cv2.FileStorage(str(tmp_path / "intrinsics.yml"), cv2.FILE_STORAGE_WRITE)
    for k, v in (
        ("M1", RIG.left.K),
        ("D1", RIG.left.D.reshape(1, -1)),
        ("M2", RIG.right.K),
        ("D2", RIG.right.D.reshape(1, -1)),
    ):
        fs.write(k, v)
    fs.write("image_width", 640)
    fs.write("image_height", 480)
    fs.release()
    fs = cv2.FileStorage(str(tmp_path / "extrinsics.yml"), cv2.FILE_STORAGE_WRITE)
    fs.write("R", RIG.R)
    fs.write("T", RIG.T.reshape(3, 1))
    fs.release()
    same(load_stereo_calibration(tmp_path / "intrinsics.yml", tmp_path / "extrinsics.yml"), RIG)


def _ros(path: Path, cam, R_rect: np.ndarray, P: np.ndarray, name: str) -> Path:  # noqa: ANN001
    mat = lambda m: {"rows": int(m.shape[0]), "cols": int(m.shape[1]), "data": [float(x) for x in m.reshape(-1)]}  # noqa: E731
    doc = {
        "image_width": cam.width,
        "image_height": cam.height,
        "camera_name": name,
        "camera_matrix": mat(cam.K),
        "distortion_model": "plumb_bob",
        "distortion_coefficients": mat(cam.D.reshape(1, -1)),
        "rectification_matrix": mat(R_rect),
        "projection_matrix": mat(P),
    }
    path.write_text(yaml.safe_dump(doc, sort_keys=False))
    return path


def test_ros_camera_info_pair_gives_the_extrinsics_back(tmp_path: Path) -> None:
    r = rectify_calibration(RIG)
    left = _ros(tmp_path / "left.yaml", RIG.left, r.R1, r.P1, "left")
    right = _ros(tmp_path / "right.yaml", RIG.right, r.R2, r.P2, "right")
    got = load_stereo_calibration(left, right)
    np.testing.assert_allclose(got.R, RIG.R, atol=1e-9)
    np.testing.assert_allclose(got.T, RIG.T, atol=1e-9)
    np.testing.assert_allclose(got.left.K, RIG.left.K)


def test_wrong_shapes_and_values_name_file_line_and_field(tmp_path: Path) -> None:
    path = tmp_path / "bad.yaml"
    path.write_text("""%YAML:1.0
---
image_width: 640
image_height: 480
M1: !!opencv-matrix
   rows: 2
   cols: 3
   dt: d
   data: [ 500., 0., 320., 0., 500., 240. ]
D1: !!opencv-matrix
   rows: 1
   cols: 3
   dt: d
   data: [ 0.1, 0.01, 0. ]
M2: !!opencv-matrix
   rows: 3
   cols: 3
   dt: d
   data: [ 500., 0., 320., 0., 500., 240., 0., 0., 1. ]
R: !!opencv-matrix
   rows: 3
   cols: 3
   dt: d
   data: [ 1., 0., 0., 0., 1., 0., 0., 0., 1. ]
T: !!opencv-matrix
   rows: 3
   cols: 1
   dt: d
   data: [ -0.1, 0., 0. ]
""")
    with pytest.raises(ConfigError) as exc:
        load_stereo_calibration(path)
    msg = str(exc.value)
    assert "bad.yaml:5:1: M1: expected a 3x3 matrix, got 2x3" in msg, msg
    assert "bad.yaml:10:1: D1: expected 4, 5, 8, 12, 14 distortion coefficients, got 3" in msg, msg
    path.write_text("%YAML:1.0\n---\nM1: !!opencv-matrix\n   rows: 3\n   cols: 3\n   dt: d\n   data: [ 1., 2. ]\n")
    with pytest.raises(ConfigError, match=r"bad.yaml:3:1: M1: rows x cols = 3x3 needs 9 numbers, `data` has 2"):
        load_stereo_calibration(path)


def test_more_bad_calibrations(tmp_path: Path) -> None:
    with pytest.raises(ConfigError, match="calibration file not found"):
        load_stereo_calibration(tmp_path / "nope.yaml")
    odd = RIG.__class__(
        RIG.left, RIG.right, RIG.R * np.array([[1.0, 1.0, 1.0], [1.0, 1.0, 1.0], [1.0, 1.0, -1.0]]), RIG.T
    )
    with pytest.raises(ConfigError, match="not a rotation matrix"):
        load_stereo_calibration(save_stereo_calibration(odd, tmp_path / "odd.yaml"))
    r = rectify_calibration(RIG)
    left = _ros(tmp_path / "l.yaml", RIG.left, r.R1, r.P1, "l")
    with pytest.raises(ConfigError, match="give the right camera's file too"):
        load_stereo_calibration(left)
    text = left.read_text().replace("rows: 3\n  cols: 3", "rows: 3\n  cols: 4", 1)
    (tmp_path / "l2.yaml").write_text(text)
    with pytest.raises(ConfigError, match=r"l2.yaml:\d+:\d+: camera_matrix: expected rows: 3, cols: 3"):
        load_stereo_calibration(tmp_path / "l2.yaml", left)
    (tmp_path / "junk.yaml").write_text("hello: world\n")
    with pytest.raises(ConfigError, match="not a stereo calibration"):
        load_stereo_calibration(tmp_path / "junk.yaml")


def test_rectified_pair_puts_a_point_on_one_row() -> None:
    r = rectify_calibration(RIG)
    rng = np.random.default_rng(0)
    X = np.column_stack([rng.uniform(-0.4, 0.4, 20), rng.uniform(-0.3, 0.3, 20), rng.uniform(0.8, 3.0, 20)])
    ul, _ = cv2.projectPoints(X.reshape(-1, 1, 3), np.zeros(3), np.zeros(3), RIG.left.K, RIG.left.D)
    rv, _ = cv2.Rodrigues(RIG.R)
    ur, _ = cv2.projectPoints(X.reshape(-1, 1, 3), rv, RIG.T, RIG.right.K, RIG.right.D)
    rl = cv2.undistortPoints(ul, RIG.left.K, RIG.left.D, R=r.R1, P=r.P1).reshape(-1, 2)
    rr = cv2.undistortPoints(ur, RIG.right.K, RIG.right.D, R=r.R2, P=r.P2).reshape(-1, 2)
    assert np.abs(rl[:, 1] - rr[:, 1]).max() < 0.05  # rows agree to a twentieth of a pixel
    depth = r.focal_px * r.baseline / (rl[:, 0] - rr[:, 0])
    np.testing.assert_allclose(depth, (X @ r.R1.T)[:, 2], rtol=2e-3)
    img = np.zeros((480, 640, 3), np.uint8)
    a, b = r.rectify(img, img)
    assert a.shape == img.shape and b.shape == img.shape
    with pytest.raises(VisionInputError, match="expected 640x480"):
        r.rectify(img[:400], img)


def test_undistort_points_inverts_the_projection() -> None:
    X = np.array([[0.3, -0.2, 1.0], [-0.45, 0.33, 1.2]])
    uv, _ = cv2.projectPoints(X.reshape(-1, 1, 3), np.zeros(3), np.zeros(3), RIG.left.K, RIG.left.D)
    np.testing.assert_allclose(undistort_points(uv.reshape(-1, 2), RIG.left), X[:, :2] / X[:, 2:], atol=1e-9)
