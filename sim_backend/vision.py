"""Stereo vision: the grasp-frame pose in the vehicle frame (vTg), ~10 Hz.

At each image time (``vision.rate_hz``) the model decides whether the pipe is
detected in that image:

* the grasp point must be in the stereo camera's field of view (camera frame:
  z optical axis, x right, y down; ``fov_h_rad`` / ``fov_v_rad`` full angles)
  and between ``min_range_m`` and the smaller of ``max_range_m`` and the
  visibility of the water (``visibility_m[turbidity]``);
* it is then detected with probability ``detection_probability[turbidity]``,
  multiplied by ``1 - occlusion_factor`` when an arm link (a cylinder of
  ``occlusion_radius_m`` around the segments between the arm points) lies
  between the camera and the grasp point (the MARIS arm mask removes part, not
  all, of the occlusion);
* no detection inside ``vision.dropouts`` or an injected ``vision_lost`` interval.

A detection carries the image time and is published ``latency_s`` later. Its
``confidence`` says how good the pose is, not how likely a detection was: it
falls linearly from 1 at the camera to 0.5 at the usable range. It comes with
position noise (camera frame: across the line of sight ``position_noise_m`` x
range, along it x range squared, as stereo triangulation does) and a small
rotation error of the axis direction. The rotation about the pipe axis is
taken from gravity in the real system, so it gets only a tenth of that noise.

Before that noise, the run's systematic errors of the vision chain
(:class:`sim_backend.vision_calibration.VisionErrors`: the stereo calibration
and the camera mount, drawn once per run) move the pose the way a real rig's
calibration errors do; with them all zero the pose is the truth plus noise.

The geometry of each image (grasp point in the camera frame, range, field of
view, occlusion) is computed by one compiled call
(:func:`sim_backend.vision_kernel.image_view`); :meth:`VisionModel.probability`
and the functions below are its numpy reference (same decisions, the range to
rounding).
"""

from __future__ import annotations

import math
from collections import deque

import numpy as np

from hal.interfaces import Detection

from .geometry import _EYE4, inverse_pose, norm, rotation_from_vector
from .sensors import in_intervals
from .vision_calibration import VisionErrors
from .vision_kernel import (
    _SAMPLES,
    N_O,
    N_V,
    O_IN_VIEW,
    O_OCCLUDED,
    O_RANGE,
    V_FOV_H,
    V_FOV_V,
    V_MAX_RANGE,
    V_MIN_RANGE,
    V_OCC_RADIUS,
    calibration_buffer,
    detection_pose,
    image_view,
)

#: The grasp-axis span (m) the calibration errors are seen through (StereoBias.apparent_pose's default).
AXIS_SPAN_M = 0.3


def in_field_of_view(p_cam: np.ndarray, fov_h: float, fov_v: float) -> bool:
    """True if the point ``p_cam`` (3,) (camera frame, z forward) is inside the view cone."""
    z = float(p_cam[2])
    if z <= 0.0:
        return False
    return abs(math.atan2(float(p_cam[0]), z)) <= 0.5 * fov_h and abs(math.atan2(float(p_cam[1]), z)) <= 0.5 * fov_v


_SEGMENT_SAMPLES = np.linspace(0.0, 1.0, 5)


def points_block_ray(target: np.ndarray, points: np.ndarray, radius: float, margin: float = 0.1) -> bool:
    """True if any of ``points`` (k, 3) lies within ``radius`` (m) of the line of
    sight from the camera origin to ``target`` (3,), in front of the target
    (closer than its range minus ``margin``). Camera frame."""
    rng = norm(target)
    if rng <= 0.0 or len(points) == 0:
        return False
    d = target / rng
    along = points.dot(d)
    perp2 = np.einsum("ij,ij->i", points, points) - along * along
    hit = (along > 0.0) & (along < rng - margin) & (perp2 < radius * radius)
    return bool(hit.any())


def sample_segments(points: np.ndarray) -> np.ndarray:
    """Points (5 per link) along the polyline through ``points`` (k, 3)."""
    a, b = points[:-1], points[1:]
    return (a[:, None, :] + _SEGMENT_SAMPLES[None, :, None] * (b - a)[:, None, :]).reshape(-1, 3)


def segment_blocks_ray(target: np.ndarray, a: np.ndarray, b: np.ndarray, radius: float, margin: float = 0.1) -> bool:
    """True if the link a-b (camera frame, m) hides ``target`` (see :func:`points_block_ray`)."""
    return points_block_ray(target, sample_segments(np.array([a, b])), radius, margin)


def occluded(target_cam: np.ndarray, arm_points_cam: np.ndarray, radius: float) -> bool:
    """True if any arm link between consecutive ``arm_points_cam`` (k, 3) hides the target."""
    pts = np.asarray(arm_points_cam, dtype=float)
    if len(pts) < 2:
        return False
    return points_block_ray(target_cam, sample_segments(pts), radius)


class VisionModel:
    """Detections of the pipe's grasp frame; :meth:`capture` is called at image times."""

    def __init__(self, params: dict, rng: np.random.Generator, turbidity: str, errors: VisionErrors | None = None):
        self.period = 1.0 / float(params["vision.rate_hz"])
        self.latency = float(params["vision.latency_s"])
        self.fov_h = float(params["vision.fov_h_rad"])
        self.fov_v = float(params["vision.fov_v_rad"])
        self.min_range = float(params["vision.min_range_m"])
        self.turbidity = turbidity
        self.max_range = min(float(params["vision.max_range_m"]), float(params["vision.visibility_m"][turbidity]))
        self.p_detect = float(params["vision.detection_probability"][turbidity])
        self.pos_noise = float(params["vision.position_noise_m"])
        self.ang_noise = float(params["vision.angle_noise_rad"])
        self.occlusion_factor = float(params["vision.occlusion_factor"])
        self.occlusion_radius = float(params["vision.occlusion_radius_m"])
        self.dropouts: list[tuple[float, float]] = list(params["vision.dropouts"])
        self._view_par = np.zeros(N_V)  # image_view's parameters and results
        self._view_par[[V_FOV_H, V_FOV_V, V_MIN_RANGE, V_MAX_RANGE, V_OCC_RADIUS]] = (
            self.fov_h,
            self.fov_v,
            self.min_range,
            self.max_range,
            self.occlusion_radius,
        )
        self._view = np.zeros(N_O)
        self._rng = rng
        #: the run's systematic errors (None: an exact calibration)
        self.errors = errors
        # detection_pose's inputs (sim_backend.vision_kernel), built once
        self._calib = calibration_buffer(
            None if errors is None else errors.stereo.triangulation_matrices,
            None if errors is None else errors.mount,
            AXIS_SPAN_M,
        )
        self._work = np.zeros((3, 4, 4))
        # loaded (first time: compiled) now, not at the first detection of a run
        detection_pose(_EYE4, _EYE4, _EYE4, self._calib, False, np.zeros(6), 0.0, 0.0, 1.0, self._work, np.eye(4))
        self.next_t = 0.0
        #: captured detections not yet published (oldest first)
        self.pending: deque[Detection] = deque()
        self._latest: Detection | None = None
        #: What the last image saw, for ground truth / logs.
        self.last_view: dict = {
            "in_view": False,
            "range_m": None,
            "occluded": False,
            "p_detect": 0.0,
            "detected": False,
        }

    def due(self, t: float) -> bool:
        return t + 1e-12 >= self.next_t

    def probability(self, target_cam: np.ndarray, arm_points_cam: np.ndarray) -> tuple[float, dict]:
        """Detection probability of one image and why (pure, no randomness)."""
        rng = norm(target_cam)
        in_view = in_field_of_view(target_cam, self.fov_h, self.fov_v) and self.min_range <= rng <= self.max_range
        occ = in_view and occluded(target_cam, arm_points_cam, self.occlusion_radius)
        p = 0.0
        if in_view:
            p = self.p_detect * ((1.0 - self.occlusion_factor) if occ else 1.0)
        return p, {"in_view": in_view, "range_m": rng, "occluded": occ, "p_detect": p}

    def capture(
        self,
        t: float,
        world_T_vehicle: np.ndarray,
        world_T_camera: np.ndarray,
        world_T_grasp: np.ndarray,
        arm_points_world: np.ndarray,
    ) -> None:
        """Take the image of time ``t`` (s); poses are (4, 4) world, arm points (k, 3) world."""
        self.next_t += self.period
        if self.next_t <= t:
            self.next_t = t + self.period
        # what probability() decides from, in one compiled call (sim_backend.vision_kernel)
        out = self._view
        image_view(world_T_camera, world_T_grasp, arm_points_world, self._view_par, _SAMPLES, out)
        res = out.tolist()  # plain floats and bools, as probability() gives them
        rng, in_view, occ = res[O_RANGE], res[O_IN_VIEW] > 0.0, res[O_OCCLUDED] > 0.0
        p = 0.0
        if in_view:
            p = self.p_detect * ((1.0 - self.occlusion_factor) if occ else 1.0)
        u, n = self._rng.random(), self._rng.standard_normal(6)  # always drawn: fixed stream order
        detected = p > 0.0 and u < p and not in_intervals(t, self.dropouts)
        view = {"in_view": in_view, "range_m": rng, "occluded": occ, "p_detect": p, "detected": detected}
        self.last_view = view
        if not detected:
            return
        noisy = np.empty((4, 4))  # (the Detection keeps it)
        detection_pose(
            world_T_vehicle,
            world_T_camera,
            world_T_grasp,
            self._calib,
            self.errors is not None,
            n,
            self.pos_noise,
            self.ang_noise,
            rng,
            self._work,
            noisy,
        )
        confidence = 1.0 - 0.5 * min(1.0, rng / self.max_range)
        self.pending.append(Detection(t=t, pose=noisy, confidence=confidence))

    def detection_pose_reference(
        self,
        world_T_vehicle: np.ndarray,
        world_T_camera: np.ndarray,
        world_T_grasp: np.ndarray,
        n: np.ndarray,
        rng: float,
    ) -> np.ndarray:
        """The pose :meth:`capture` reports for a detection (vehicle frame, 4 x 4) from the
        six normal draws ``n`` and the range ``rng`` (m), in numpy: the reference of
        :func:`sim_backend.vision_kernel.detection_pose` (same formulas; the sums in
        another order, so equal to rounding)."""
        cam_T_world = inverse_pose(world_T_camera)
        vehicle_T_world = inverse_pose(world_T_vehicle)
        if self.errors is None:
            vTg = vehicle_T_world.dot(world_T_grasp)
        else:
            vTc = vehicle_T_world.dot(world_T_camera)
            vTg = self.errors.measured_vehicle_pose(vTc, cam_T_world.dot(world_T_grasp))
        r = max(rng, 0.5)
        # stereo: lateral error grows with range, depth error with range squared
        err_cam = np.array([self.pos_noise * r * n[3], self.pos_noise * r * n[4], self.pos_noise * r * r * n[5]])
        noisy = vTg.copy()
        dR = rotation_from_vector(np.array([0.1 * self.ang_noise * n[0], self.ang_noise * n[1], self.ang_noise * n[2]]))
        noisy[:3, :3] = vTg[:3, :3].dot(dR)
        noisy[:3, 3] = vTg[:3, 3] + vehicle_T_world[:3, :3].dot(world_T_camera[:3, :3].dot(err_cam))
        return noisy

    def publish(self, t: float) -> None:
        """Release the detections whose processing has finished by time ``t``."""
        while self.pending and self.pending[0].t + self.latency <= t + 1e-12:
            self._latest = self.pending.popleft()

    def latest(self) -> Detection | None:
        return self._latest
