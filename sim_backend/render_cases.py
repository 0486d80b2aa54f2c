"""Rendered stereo pairs with known truth, for tests and benchmarks.

:func:`view_case` places the stereo rig at a chosen range and viewing angle
from the pipe's grasp point (the pipe lying on the pool floor as in the
scenarios), renders the pair and returns it with the truth in the left camera
frame and the vehicle frame. Viewing angles: ``elevation`` of the line of
sight above the floor (rad; the rig is pitched down 55 deg on the vehicle, so
about 0.96 rad is a level vehicle looking at it), ``azimuth`` between the
line of sight (seen from above) and the pipe axis (rad; pi/2: across the
pipe). The rig's image rows stay level.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from kcl.model import UvmsModel
from vision.calibration import StereoCalibration, ideal_stereo

from .render import Scene, StereoRenderer
from .render_optics import WaterOptics
from .schema import PARAMS_BY_KEY

#: The Mako G-125 (1292 x 964, 3.75 um pixels) behind a 4.4 mm lens: ~1.0 rad wide.
FULL_SIZE = (1292, 964)
FOV_H_RAD = 1.007


def default_calibration(width: int = 646, height: int = 482, baseline: float = 0.2) -> StereoCalibration:
    """The simulator's rig: Mako-like cameras with mild barrel distortion, the right
    camera ``baseline`` m to the right and mounted a fraction of a degree askew."""
    return ideal_stereo(
        width,
        height,
        FOV_H_RAD,
        baseline,
        distortion=(-0.08, 0.02, 0.0, 0.0, 0.0),
        right_rotation_rpy=(0.002, -0.004, 0.003),
    )


def visibility(turbidity: str) -> float:
    """The scenarios' default water visibility (m) for rendering, per turbidity level."""
    return float(PARAMS_BY_KEY["vision.water_visibility_m"].default[turbidity])


@dataclass
class Case:
    """One rendered pair and its truth (left camera frame, m)."""

    left: np.ndarray
    right: np.ndarray
    calib: StereoCalibration
    cam_T_grasp: np.ndarray
    cam_T_centre: np.ndarray
    gravity_cam: np.ndarray
    vehicle_T_camera: np.ndarray
    range_m: float


def _look_at(eye: np.ndarray, target: np.ndarray) -> np.ndarray:
    """World pose (4, 4) of an optical frame at ``eye`` looking at ``target``, image rows level (NED world)."""
    z = target - eye
    z /= np.linalg.norm(z)
    x = np.cross([0.0, 0.0, 1.0], z)  # right: horizontal
    if np.linalg.norm(x) < 1e-6:
        x = np.array([0.0, 1.0, 0.0])
    x /= np.linalg.norm(x)
    y = np.cross(z, x)
    T = np.eye(4)
    T[:3, :3] = np.column_stack([x, y, z])
    T[:3, 3] = eye
    return T


def view_case(
    range_m: float,
    *,
    elevation: float = 0.96,
    azimuth: float = np.pi / 2,
    turbidity: str = "clear",
    calib: StereoCalibration | None = None,
    seed: int = 0,
    renderer: StereoRenderer | None = None,
    aim_offset_m: float = 0.0,
    arm_points_world: np.ndarray | None = None,
    t: float = 0.0,
) -> Case:
    """Render the pipe (1 m long, 5 cm radius, 5 cm above a 4 m deep floor) seen
    from ``range_m`` at the given angles; ``aim_offset_m`` shifts the aim point
    along the pipe axis (towards its +x end) so that one end is well in view."""
    calib = calib or default_calibration()
    if renderer is None:
        renderer = StereoRenderer(calib, WaterOptics.for_visibility(visibility(turbidity)), np.random.default_rng(seed))
    pipe = np.eye(4)
    pipe[:3, 3] = (12.5, 6.0, 4.0 - 0.05 - 0.05)
    axis = pipe[:3, 0]
    aim = pipe[:3, 3] + aim_offset_m * axis
    horiz = np.array([np.cos(azimuth), np.sin(azimuth), 0.0])  # from the pipe towards the camera, seen from above
    eye = aim + range_m * (np.cos(elevation) * horiz + np.array([0.0, 0.0, -np.sin(elevation)]))
    wTc = _look_at(eye, aim)
    scene = Scene((25.0, 12.0, 4.0), pipe, 1.0, 0.05, arm_points_world, 0.07, 0.10, t)
    left, right = renderer.render(scene, wTc)
    cTw = np.linalg.inv(wTc)
    cTc = cTw @ pipe
    vTc = _rig_mount()
    return Case(
        left,
        right,
        calib,
        cTc.copy(),
        cTc,
        cTw[:3, :3] @ np.array([0.0, 0.0, 1.0]),
        vTc,
        float(np.linalg.norm(pipe[:3, 3] - eye)),
    )


_MOUNT: list[np.ndarray] = []


def _rig_mount() -> np.ndarray:
    """Pose (4, 4) of the stereo rig in the vehicle frame (the shipped URDF)."""
    if not _MOUNT:
        m = UvmsModel.load()
        _MOUNT.append(m.frame_pose_vehicle(np.zeros(m.n_joints), "stereo_camera"))
    return _MOUNT[0]
