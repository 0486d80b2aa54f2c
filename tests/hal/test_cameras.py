"""Camera sources, stereo pairing and the stereo pipe detector driver, against
real OpenCV inputs: image folders, a video file, and an MJPEG-over-HTTP camera
in another process on 127.0.0.1 (hal.testing.mjpeg_camera)."""

from __future__ import annotations

import time
from pathlib import Path

import cv2
import numpy as np
import pytest

from hal.drivers.camera import CameraError, CameraSource
from hal.drivers.pipe_detector import StereoPipeDetector
from hal.drivers.stereo import StereoCamera
from hal.interfaces import HealthState, NavigationState
from hal.testing.peers import Peer, wait_until
from sim_backend.render_cases import default_calibration, view_case
from vision.calibration import save_stereo_calibration


@pytest.fixture(scope="module")
def recording(tmp_path_factory) -> Path:  # noqa: ANN001
    """Six rendered stereo pairs (folders L/ and R/) and their calibration."""
    d = tmp_path_factory.mktemp("rec")
    calib = default_calibration()
    save_stereo_calibration(calib, d / "calib.yaml")
    (d / "L").mkdir()
    (d / "R").mkdir()
    for i in range(6):
        c = view_case(1.2 + 0.04 * i, azimuth=1.1, aim_offset_m=0.3, calib=calib, seed=i)
        cv2.imwrite(str(d / "L" / f"{i:03d}.png"), c.left)
        cv2.imwrite(str(d / "R" / f"{i:03d}.png"), c.right)
    return d


@pytest.mark.slow
def test_image_folder_source_delivers_then_goes_stale(recording: Path, tmp_path: Path) -> None:
    folder = tmp_path / "frames"
    folder.mkdir()
    for i in range(3):
        (folder / f"{i}.png").write_bytes((recording / "L" / f"{i:03d}.png").read_bytes())
    (folder / "1b.png").write_bytes(b"\x89PNG\r\n\x1a\n truncated")  # a corrupt frame in the middle
    cam = CameraSource("left", {"source": str(folder), "fps": 20, "stale_timeout": 0.3}, time.monotonic)
    cam.connect()
    try:
        assert wait_until(lambda: cam.ended, 3.0)
        assert cam.latest() is not None and cam.latest().seq == 3 and cam.corrupt == 1
        d = cam.details(time.monotonic())
        assert d["resolution"] == "646x482" and d["frames"] == 3 and d["corrupt"] == 1
        assert wait_until(lambda: cam.health(time.monotonic()).state == HealthState.FAULT, 2.0)
        h = cam.health(time.monotonic())
        assert "camera left: stale" in h.detail and "end of the recording" in h.detail
    finally:
        cam.disconnect()


@pytest.mark.slow
def test_video_file_source(recording: Path, tmp_path: Path) -> None:
    path = tmp_path / "clip.avi"
    vw = cv2.VideoWriter(str(path), cv2.VideoWriter_fourcc(*"MJPG"), 10.0, (646, 482))
    for i in range(5):
        vw.write(cv2.imread(str(recording / "L" / f"{i:03d}.png")))
    vw.release()
    cam = CameraSource("left", {"source": str(path), "fps": 50}, time.monotonic)
    assert cam.kind == "ffmpeg" and not cam.live
    cam.connect()
    try:
        assert wait_until(lambda: cam.ended, 3.0)
        assert cam.latest().seq == 5 and cam.latest().image.shape == (482, 646, 3)
    finally:
        cam.disconnect()


def test_sources_that_cannot_open_say_why(tmp_path: Path) -> None:
    for params, msg in (
        ({"source": str(tmp_path / "nope")}, "video file .* does not exist"),
        ({"source": str(tmp_path), "backend": "images"}, "holds no images"),
        ({"source": "udpsrc port=5600 ! rtph264depay ! avdec_h264 ! appsink"}, "GStreamer"),
    ):
        with pytest.raises(CameraError, match="camera left: .*" + msg):
            CameraSource("left", params, time.monotonic).connect()


@pytest.mark.slow
def test_a_missing_camera_of_the_pair_is_named_and_nothing_stays_open(recording: Path, tmp_path: Path) -> None:
    stereo = StereoCamera(
        {"left": {"source": str(recording / "L")}, "right": {"source": "/dev/video63"}}, time.monotonic
    )
    with pytest.raises(CameraError, match="camera right: cannot open /dev/video63"):
        stereo.connect()
    assert stereo.cameras["left"]._cap is None  # the left one was released again
    h = stereo.health(time.monotonic())
    assert h.state == HealthState.MISSING and "camera right: not connected" in h.detail


@pytest.fixture
def ipcam(recording: Path):  # noqa: ANN001, ANN201
    peer = Peer(
        "hal.testing.mjpeg_camera", "--left", str(recording / "L"), "--right", str(recording / "R"), "--fps", "10"
    )
    yield peer
    peer.stop()


@pytest.mark.peer
@pytest.mark.slow
def test_network_cameras_pair_stall_and_recover(ipcam) -> None:  # noqa: ANN001
    port = int(ipcam.ready)
    stereo = StereoCamera(
        {
            "left": {"source": f"http://127.0.0.1:{port}/left"},
            "right": {"source": f"http://127.0.0.1:{port}/right"},
            "pairing_tolerance_s": 0.05,
            "stale_timeout_s": 0.5,
        },
        time.monotonic,
    )
    stereo.connect()
    try:
        assert wait_until(lambda: stereo.latest_pair() is not None, 8.0)
        t, left, right = stereo.latest_pair()
        assert left.shape == right.shape == (482, 646, 3)
        assert wait_until(lambda: stereo.health(time.monotonic()).state == HealthState.OK, 3.0)
        assert wait_until(lambda: stereo.details(time.monotonic())["right"]["fps"] is not None, 3.0)
        info = stereo.details(time.monotonic())
        assert info["left"]["resolution"] == "646x482" and 3.0 < info["right"]["fps"] < 30.0
        seq = stereo.cameras["left"].latest().seq
        ipcam.send(cmd="corrupt", camera="left", n=2)  # cut-short JPEGs: FFmpeg conceals them, the stream goes on
        assert wait_until(lambda: stereo.cameras["left"].latest().seq > seq + 4, 3.0)
        ipcam.send(cmd="stall", camera="right")  # a frozen camera: connection open, no frames
        assert wait_until(lambda: stereo.health(time.monotonic()).state == HealthState.FAULT, 5.0)
        assert "camera right: stale" in stereo.health(time.monotonic()).detail
        ipcam.send(cmd="resume")
        assert wait_until(lambda: stereo.health(time.monotonic()).state == HealthState.OK, 15.0), stereo.health(
            time.monotonic()
        )
    finally:
        stereo.disconnect()


@pytest.mark.slow
def test_side_by_side_source_is_split(recording: Path, tmp_path: Path) -> None:
    folder = tmp_path / "sbs"
    folder.mkdir()
    img = np.hstack([cv2.imread(str(recording / "L" / "000.png")), cv2.imread(str(recording / "R" / "000.png"))])
    cv2.imwrite(str(folder / "0.png"), img)
    stereo = StereoCamera({"side_by_side": {"source": str(folder), "loop": True, "fps": 20}}, time.monotonic)
    stereo.connect()
    try:
        assert wait_until(lambda: stereo.latest_pair() is not None, 3.0)
        _, left, right = stereo.latest_pair()
        assert left.shape == right.shape == (482, 646, 3)
        np.testing.assert_array_equal(right, img[:, 646:])
    finally:
        stereo.disconnect()


class _OneJointArm:
    class _Js:
        position = np.zeros(1)

    def joint_state(self):  # noqa: ANN201
        return self._Js()


class _StillVehicle:
    class _Nav:
        attitude = np.zeros(3)

    def navigation(self):  # noqa: ANN201
        return self._Nav()


@pytest.mark.slow
def test_detector_driver_on_a_recording(recording: Path) -> None:
    params = {
        "calibration": str(recording / "calib.yaml"),
        "left": {"source": str(recording / "L"), "loop": True, "fps": 10},
        "right": {"source": str(recording / "R"), "loop": True, "fps": 10},
        "sync": "sequence",
        "rate_hz": 10.0,
        "log_frames_hz": 2.0,
    }
    det = StereoPipeDetector(params, time.monotonic)
    assert det.latest() is None
    assert (
        det.health().info["starting"] == "detector: no pair processed yet"
    )  # `maris hal check` waits for the first pair
    det.connect()
    try:
        assert wait_until(lambda: det.latest() is not None, 20.0), det.health()
        d = det.latest()
        assert 0.6 < d.confidence <= 1.0 and d.pose.shape == (4, 4) and d.details["end_cam"] is not None
        assert time.monotonic() - d.t < 5.0  # the image's time, on the backend clock
        assert wait_until(lambda: det.health().state == HealthState.OK and det.worker.processed >= 2, 20.0), (
            det.health()
        )
        parts = {p["name"]: p for p in det.health().info["parts"]}  # the rows of `maris hal check`
        assert parts["camera left"]["resolution"] == "646x482" and parts["camera right"]["frame_age_s"] is not None
        assert parts["camera left"]["state"] == "ok" and parts["detector"]["processing_ms"] > 0
        assert "starting" not in det.health().info
        frames = det.camera_frames()
        assert frames and frames[0].jpeg[:2] == b"\xff\xd8" and frames[0].overlay["lines"]
    finally:
        det.disconnect()


@pytest.mark.slow
def test_detector_driver_reports_images_that_do_not_fit_the_calibration(recording: Path, tmp_path: Path) -> None:
    for side in ("L", "R"):
        (tmp_path / side).mkdir()
        img = cv2.imread(str(recording / side / "000.png"))
        cv2.imwrite(str(tmp_path / side / "0.png"), img[:400])  # cropped: another aspect ratio
    params = {
        "calibration": str(recording / "calib.yaml"),
        "left": {"source": str(tmp_path / "L"), "loop": True, "fps": 10},
        "right": {"source": str(tmp_path / "R"), "loop": True, "fps": 10},
        "sync": "sequence",
    }
    det = StereoPipeDetector(params, time.monotonic)
    det.attach(vehicle=_StillVehicle(), arm=_OneJointArm())
    det.connect()
    try:
        assert wait_until(lambda: det.health().state == HealthState.DEGRADED, 15.0), det.health()
        assert "different aspect ratio" in det.health().detail and det.latest() is None
        assert "arm mask off: the arm reports 1 joint(s), the URDF r2_uma.urdf has 7" in det.worker.warning
    finally:
        det.disconnect()


class _MovingVehicle:
    """A vehicle whose navigation (position, attitude, a DVL velocity) is set per image."""

    def __init__(self) -> None:
        self.nav: NavigationState | None = None

    def navigation(self) -> NavigationState:
        assert self.nav is not None
        return self.nav


@pytest.mark.slow
def test_detector_driver_tracks_the_pipe_through_a_moving_vehicle_an_intermittent_end_and_an_outlier(
    recording: Path,
) -> None:
    """The driver's track (world frame of the navigation): the vehicle moves between
    images, the pipe end is in view in one pair of three, one pair's detection is
    0.4 m off in the world (a wrong detection); the tracked grasp frame in the world
    stays within 1 cm, the wrong one is rejected and the confidence stays high."""
    from kcl.rotations import pose_matrix
    from sim_backend.render import StereoRenderer
    from sim_backend.render_cases import visibility
    from sim_backend.render_optics import WaterOptics

    calib = default_calibration()
    rend = StereoRenderer(calib, WaterOptics.for_visibility(visibility("clear")), np.random.default_rng(5))
    params = {  # the recording's folders: sources that exist (the test feeds the pairs to process())
        "calibration": str(recording / "calib.yaml"),
        "left": {"source": str(recording / "L")},
        "right": {"source": str(recording / "R")},
    }
    now = [0.0]  # the backend clock: the image times
    det = StereoPipeDetector(params, lambda: now[0])
    vehicle = _MovingVehicle()
    det.attach(vehicle=vehicle)
    pipe = np.eye(4)
    pipe[:3, 3] = (12.5, 6.0, 4.0 - 0.05 - 0.05)  # where sim_backend.render_cases.view_case puts the pipe
    navs: dict[float, np.ndarray] = {}
    world, confs = [], []
    for i in range(18):
        end = i % 3 == 0
        c = view_case(
            1.1 + 0.02 * (i % 5),
            azimuth=1.2 + 0.03 * (i % 4),
            aim_offset_m=0.3 if end else 0.0,  # aimed at the middle from 1.1 m: both ends out of view
            calib=calib,
            renderer=rend,
            seed=i,
        )
        wTv = pipe @ np.linalg.inv(c.cam_T_centre) @ np.linalg.inv(c.vehicle_T_camera)
        if i == 10:  # the navigation 0.4 m off for this image: its detection is wrong in the world
            wTv = wTv.copy()
            wTv[:3, 3] += (0.4, 0.0, 0.0)
        R = wTv[:3, :3]
        rpy = np.array(
            [np.arctan2(R[2, 1], R[2, 2]), -np.arcsin(np.clip(R[2, 0], -1, 1)), np.arctan2(R[1, 0], R[0, 0])]
        )
        np.testing.assert_allclose(pose_matrix(np.concatenate([wTv[:3, 3], rpy])), wTv, atol=1e-9)
        vehicle.nav = NavigationState(0.1 * i, wTv[:3, 3].copy(), rpy, np.zeros(6), 0.1 * i, 3.0, 1.0)
        navs[0.1 * i] = wTv
        now[0] = 0.1 * i
        det.process(0.1 * i, c.left, c.right)
        d = det.latest()
        if i >= 3:
            assert d is not None
            world.append(navs[d.t] @ d.pose)
            confs.append(d.confidence)
    tr = det.latest().details["tracker"]
    assert tr["frame"] == "world" and tr["rejected"] == 1 and tr["state"] == "tracking", tr
    pts = np.array([w[:3, 3] for w in world])
    assert np.linalg.norm(pts[:, None] - pts[None], axis=2).max() < 0.01
    assert min(confs) > 0.6
