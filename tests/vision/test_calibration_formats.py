"""Calibration files as the tools write them: OpenCV FileStorage (stereo and per
camera, under the key names common tools use), ROS camera_info, Kalibr camchain
(radtan and equidistant). Every format loads to the same numbers as the ROS
files, and a missing distortion is an error or an explicit choice, never a zero.

The files are written by the tools' own writers: ``cv2.FileStorage`` for the
OpenCV files; for Kalibr, ``yaml.dump`` of the dictionary Kalibr's
``CameraChainParameters`` builds (kalibr_common/ConfigReader.py: per camera
``camera_model``, ``intrinsics`` [fu, fv, pu, pv], ``distortion_model``,
``distortion_coeffs``, ``resolution`` [w, h], ``rostopic``, ``cam_overlaps``;
``T_cn_cnm1`` from cam n-1 to cam n as a 4x4 nested list; written with
``yaml.dump(self.data)``); for ROS, the camera_info YAML of
camera_calibration_parsers (``image_width``, ``image_height``, ``camera_name``,
``camera_matrix``/``distortion_coefficients``/``rectification_matrix``/
``projection_matrix`` as ``rows``/``cols``/``data``, ``distortion_model``).
"""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np
import pytest
import yaml
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from maris_common.yamlsrc import ConfigError
from vision.calibration import CameraModel, StereoCalibration, load_stereo_calibration, undistort_points
from vision.rectify import rectify_calibration


def rig(
    f: float = 612.0,
    cx: float = 318.4,
    cy: float = 242.7,
    dist: tuple[float, ...] = (-0.11, 0.035, 0.0012, -0.0007),
    rvec: tuple[float, float, float] = (0.004, -0.011, 0.002),
    t: tuple[float, float, float] = (-0.12, 0.0009, -0.0004),
    model: str = "radtan",
) -> StereoCalibration:
    """A 640 x 480 rig with 4 distortion coefficients (what Kalibr's radtan and equidistant hold)."""
    K1 = np.array([[f, 0.0, cx], [0.0, f * 1.0011, cy], [0.0, 0.0, 1.0]])
    K2 = np.array([[f * 0.9987, 0.0, cx + 3.1], [0.0, f * 0.9993, cy - 1.7], [0.0, 0.0, 1.0]])
    D1 = np.array(dist, float)
    D2 = np.array(dist, float) * np.array([0.97, 1.05, -0.8, 1.3])
    if model == "radtan":  # OpenCV's five-coefficient form, k3 = 0: how every reader returns it
        D1, D2 = np.append(D1, 0.0), np.append(D2, 0.0)
    R = cv2.Rodrigues(np.array(rvec, float))[0]
    return StereoCalibration(
        CameraModel(640, 480, K1, D1, "left", model), CameraModel(640, 480, K2, D2, "right", model), R, np.array(t)
    )


def assert_same(a: StereoCalibration, b: StereoCalibration, tol: float = 1e-9) -> None:
    for ca, cb in ((a.left, b.left), (a.right, b.right)):
        assert ca.size == cb.size and ca.model == cb.model
        np.testing.assert_allclose(ca.K, cb.K, rtol=0, atol=tol)
        np.testing.assert_allclose(ca.D, cb.D, rtol=0, atol=tol)
    np.testing.assert_allclose(a.R, b.R, rtol=0, atol=tol)
    np.testing.assert_allclose(a.T, b.T, rtol=0, atol=tol)


# --------------------------------------------------------------------------- writers


def write_ros(c: StereoCalibration, folder: Path) -> tuple[Path, Path]:
    """camera_info YAML of both cameras (rectification from OpenCV, as camera_calibration does)."""
    r = rectify_calibration(c)
    out = []
    for name, cam, Rr, P in (("left", c.left, r.R1, r.P1), ("right", c.right, r.R2, r.P2)):

        def mat(m: np.ndarray) -> dict:
            return {"rows": int(m.shape[0]), "cols": int(m.shape[1]), "data": [float(x) for x in m.reshape(-1)]}

        doc = {
            "image_width": cam.width,
            "image_height": cam.height,
            "camera_name": name,
            "camera_matrix": mat(cam.K),
            "distortion_model": "equidistant" if cam.model == "equidistant" else "plumb_bob",
            "distortion_coefficients": mat(cam.D.reshape(1, -1)),
            "rectification_matrix": mat(Rr),
            "projection_matrix": mat(P),
        }
        p = folder / f"{name}.yaml"
        p.write_text(yaml.safe_dump(doc, sort_keys=False))
        out.append(p)
    return out[0], out[1]


def write_opencv_stereo(c: StereoCalibration, path: Path, names: tuple[str, ...]) -> Path:
    """One cv2.FileStorage file with both cameras under ``names`` = (K1, D1, K2, D2)."""
    fs = cv2.FileStorage(str(path), cv2.FILE_STORAGE_WRITE)
    fs.write("image_width", c.left.width)
    fs.write("image_height", c.left.height)
    for key, value in zip(names, (c.left.K, c.left.D.reshape(1, -1), c.right.K, c.right.D.reshape(1, -1))):
        fs.write(key, value)
    fs.write("R", c.R)
    fs.write("T", c.T.reshape(3, 1))
    fs.release()
    return path


def write_opencv_per_camera(c: StereoCalibration, folder: Path, suffix: str = ".yml") -> tuple[Path, Path]:
    """Two cv2.FileStorage files as OpenCV's calibration sample writes them; the right one with R and T."""
    out = []
    for name, cam in (("left", c.left), ("right", c.right)):
        p = folder / f"{name}{suffix}"
        fs = cv2.FileStorage(str(p), cv2.FILE_STORAGE_WRITE)
        fs.write("calibration_time", "Sun Dec  6 10:00:00 2026")
        fs.write("image_width", cam.width)
        fs.write("image_height", cam.height)
        fs.write("flags", 0)
        fs.write("camera_matrix", cam.K)
        fs.write("distortion_coefficients", cam.D.reshape(-1, 1))
        fs.write("avg_reprojection_error", 0.21)
        if name == "right":
            fs.write("R", c.R)
            fs.write("T", c.T.reshape(3, 1))
        fs.release()
        out.append(p)
    return out[0], out[1]


def write_kalibr(c: StereoCalibration, path: Path) -> Path:
    """A camchain.yaml as Kalibr writes it: ``yaml.dump`` of CameraChainParameters' dictionary."""
    model = "equidistant" if c.left.model == "equidistant" else "radtan"

    def cam(m: CameraModel, topic: str, overlaps: list[int]) -> dict:
        return {
            "cam_overlaps": overlaps,
            "camera_model": "pinhole",
            "distortion_coeffs": [float(x) for x in m.D[:4]],
            "distortion_model": model,
            "intrinsics": [float(m.K[0, 0]), float(m.K[1, 1]), float(m.K[0, 2]), float(m.K[1, 2])],
            "resolution": [m.width, m.height],
            "rostopic": topic,
        }

    T = np.eye(4)
    T[:3, :3], T[:3, 3] = c.R, c.T
    data = {"cam0": cam(c.left, "/cam0/image_raw", [1]), "cam1": cam(c.right, "/cam1/image_raw", [0])}
    data["cam1"]["T_cn_cnm1"] = T.tolist()
    path.write_text(yaml.dump(data))
    return path


# --------------------------------------------------------------------------- every format, the same numbers

_KEY_SETS = {
    "camera_matrix_left": (
        "camera_matrix_left",
        "distortion_coefficients_left",
        "camera_matrix_right",
        "distortion_coefficients_right",
    ),
    "M1": ("M1", "D1", "M2", "D2"),
    "cameraMatrix1": ("cameraMatrix1", "distCoeffs1", "cameraMatrix2", "distCoeffs2"),
}


@pytest.mark.parametrize("keys", sorted(_KEY_SETS))
@pytest.mark.parametrize("suffix", [".yml", ".xml", ".json"])
def test_opencv_stereo_files_load_as_the_ros_files(tmp_path: Path, keys: str, suffix: str) -> None:
    c = rig()
    ros = load_stereo_calibration(*write_ros(c, tmp_path))
    got = load_stereo_calibration(write_opencv_stereo(c, tmp_path / f"stereo{suffix}", _KEY_SETS[keys]))
    assert_same(got, ros)
    assert_same(got, c, 1e-12)


@pytest.mark.parametrize("suffix", [".yml", ".xml"])
def test_opencv_per_camera_files_load_as_the_ros_files(tmp_path: Path, suffix: str) -> None:
    c = rig()
    ros = load_stereo_calibration(*write_ros(c, tmp_path))
    assert_same(load_stereo_calibration(*write_opencv_per_camera(c, tmp_path, suffix)), ros)


@pytest.mark.parametrize("model", ["radtan", "equidistant"])
def test_kalibr_camchain_loads_as_the_ros_files(tmp_path: Path, model: str) -> None:
    c = rig(
        dist=(0.021, -0.006, 0.0011, -0.0003) if model == "equidistant" else (-0.11, 0.035, 0.0012, -0.0007),
        model=model,
    )
    ros = load_stereo_calibration(*write_ros(c, tmp_path))
    got = load_stereo_calibration(write_kalibr(c, tmp_path / "camchain.yaml"))
    assert_same(got, ros)
    assert got.left.model == model


@settings(max_examples=12, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(
    f=st.floats(300.0, 1500.0),
    cx=st.floats(280.0, 360.0),
    cy=st.floats(200.0, 280.0),
    k=st.tuples(st.floats(-0.3, 0.1), st.floats(-0.05, 0.1), st.floats(-0.003, 0.003), st.floats(-0.003, 0.003)),
    # OpenCV's stereoRectify, which writes the ROS files' rectification, takes a rotation
    # under 1e-5 rad for none (its Rodrigues conversion): the ROS files of such a rig hold
    # no rotation, so the formats are compared on rotations those files can hold
    rvec=st.tuples(*[st.floats(-0.05, 0.05).filter(lambda x: x == 0.0 or abs(x) > 1e-4)] * 3),
    base=st.floats(0.05, 0.4),
)
def test_every_format_gives_the_same_rig(tmp_path_factory, f, cx, cy, k, rvec, base) -> None:  # noqa: ANN001
    folder = tmp_path_factory.mktemp("rig")
    c = rig(f, cx, cy, k, rvec, (-base, 0.001, -0.0005))
    ros = load_stereo_calibration(*write_ros(c, folder))
    for loaded in (
        load_stereo_calibration(write_opencv_stereo(c, folder / "s.yml", _KEY_SETS["camera_matrix_left"])),
        load_stereo_calibration(write_opencv_stereo(c, folder / "m.yml", _KEY_SETS["M1"])),
        load_stereo_calibration(*write_opencv_per_camera(c, folder)),
        load_stereo_calibration(write_kalibr(c, folder / "camchain.yaml")),
    ):
        assert_same(loaded, ros)


def test_equidistant_points_undistort_through_the_fisheye_model(tmp_path: Path) -> None:
    c = load_stereo_calibration(
        write_kalibr(rig(dist=(0.021, -0.006, 0.0011, -0.0003), model="equidistant"), tmp_path / "k.yaml")
    )
    X = np.array([[0.3, -0.2, 1.0], [-0.45, 0.33, 1.2], [0.0, 0.0, 2.0]])
    uv, _ = cv2.fisheye.projectPoints(X.reshape(-1, 1, 3), np.zeros(3), np.zeros(3), c.left.K, c.left.D)
    np.testing.assert_allclose(undistort_points(uv.reshape(-1, 2), c.left), X[:, :2] / X[:, 2:], atol=1e-9)
    r = rectify_calibration(c)
    assert r.P1[0, 0] > 0 and r.baseline == pytest.approx(c.baseline, rel=1e-6)


# --------------------------------------------------------------------------- distortion: an error or a choice


def _stereo_without_distortion(c: StereoCalibration, p: Path, choice: str | None) -> Path:
    fs = cv2.FileStorage(str(p), cv2.FILE_STORAGE_WRITE)
    fs.write("image_width", 640)
    fs.write("image_height", 480)
    fs.write("camera_matrix_left", c.left.K)
    fs.write("camera_matrix_right", c.right.K)
    fs.write("R", c.R)
    fs.write("T", c.T.reshape(3, 1))
    if choice is not None:
        fs.write("distortion", choice)
    fs.release()
    return p


def test_a_stereo_file_without_distortion_is_an_error_naming_the_keys(tmp_path: Path) -> None:
    c = rig()
    with pytest.raises(ConfigError) as exc:
        load_stereo_calibration(_stereo_without_distortion(c, tmp_path / "stereo.yml", None))
    msg = str(exc.value)
    assert "missing the left camera's distortion coefficients: looked for D1" in msg, msg
    assert "distortion_coefficients_left" in msg and "distortion_coefficients_right" in msg
    assert "`distortion: none`" in msg
    # the explicit choice
    got = load_stereo_calibration(_stereo_without_distortion(c, tmp_path / "none.yml", "none"))
    assert got.left.D.size == 0 and got.right.D.size == 0


def test_per_camera_and_kalibr_files_without_distortion_are_errors(tmp_path: Path) -> None:
    c = rig()
    left, right = write_opencv_per_camera(c, tmp_path)
    text = right.read_text()
    start = text.index("distortion_coefficients")
    end = text.index("avg_reprojection_error")
    right.write_text(text[:start] + text[end:])
    with pytest.raises(
        ConfigError,
        match=r"right.yml:1:1: <root>: missing the right camera's distortion coefficients: looked for distortion_coefficients",
    ):
        load_stereo_calibration(left, right)
    with pytest.raises(ConfigError, match="left.yml:1:1: <root>: missing R and T"):
        load_stereo_calibration(left, left)  # the left camera's file twice: no pose of the right camera
    k = write_kalibr(c, tmp_path / "camchain.yaml")
    data = yaml.safe_load(k.read_text())
    del data["cam1"]["distortion_coeffs"]
    k.write_text(yaml.dump(data))
    with pytest.raises(ConfigError, match=r"camchain.yaml:\d+:\d+: cam1: missing `distortion_coeffs`"):
        load_stereo_calibration(k)
    data["cam1"]["distortion_coeffs"] = [0.1, 0.2]
    k.write_text(yaml.dump(data))
    with pytest.raises(ConfigError, match=r"cam1.distortion_coeffs: distortion model `radtan` has 4 coefficients"):
        load_stereo_calibration(k)
    data["cam1"]["distortion_coeffs"] = []
    data["cam1"]["distortion_model"] = "none"
    data["cam0"]["distortion_coeffs"] = []
    data["cam0"]["distortion_model"] = "none"
    k.write_text(yaml.dump(data))
    assert load_stereo_calibration(k).left.D.size == 0


def test_bad_kalibr_files_name_the_field(tmp_path: Path) -> None:
    c = rig()
    k = write_kalibr(c, tmp_path / "camchain.yaml")
    data = yaml.safe_load(k.read_text())
    data["cam0"]["camera_model"] = "omni"
    data["cam1"]["T_cn_cnm1"][3] = [0.0, 0.0, 1.0, 1.0]
    k.write_text(yaml.dump(data))
    with pytest.raises(ConfigError) as exc:
        load_stereo_calibration(k)
    msg = str(exc.value)
    assert "cam0.camera_model: camera model `omni` is not supported" in msg, msg
    assert "cam1.T_cn_cnm1: the last row of a homogeneous transform must be [0, 0, 0, 1]" in msg, msg
    del data["cam1"]
    data["cam0"]["camera_model"] = "pinhole"
    k.write_text(yaml.dump(data))
    with pytest.raises(ConfigError, match="missing `cam1`"):
        load_stereo_calibration(k)


def test_one_per_camera_file_asks_for_the_other(tmp_path: Path) -> None:
    left, _ = write_opencv_per_camera(rig(), tmp_path)
    with pytest.raises(ConfigError, match="this file holds one camera"):
        load_stereo_calibration(left)
