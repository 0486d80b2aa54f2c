"""Vision in the loop: rendered stereo images and the real pipe detector.

Selected with ``vision.model: rendered`` in a scenario (the default ``table``
model is :mod:`sim_backend.vision`). At each image time (``vision.rate_hz``)
:class:`RenderedVision` renders the two cameras (:mod:`sim_backend.render`:
pool, pipe, the arm where it is in view, the water of the scenario's
turbidity), then runs the same detector as the field
(:class:`vision.pipeline.PipePoseEstimator`, with the arm mask from the
measured joint angles and gravity from the AHRS attitude). A detection with a
positive confidence goes through the tracker of the vehicle's driver
(:class:`vision.tracking.DetectionTracker`, in the world frame of the
simulated navigation) and the track is published ``vision.latency_s`` after
its image time, as in the table model; detection rate versus turbidity
therefore comes out of the detector. ``vision.dropouts`` / injected ``vision_lost`` suppress
detections as before. Everything is deterministic for a seed.

The images come from the real rig; the detector works with the calibration
it believes (the run's :class:`sim_backend.vision_calibration.VisionErrors`,
exact when their standard deviations are zero), and the camera mount error
moves the pose it reports, as in the table model.

Camera frames for the run log (left image, downscaled JPEG with the
detection's drawing) are produced at ``vision.log_frames_hz``, only when the
log asks for them (:meth:`RenderedVision.camera_frames`).
"""

from __future__ import annotations

from collections import deque
from typing import TYPE_CHECKING

import numpy as np

from hal.interfaces import CameraFrame, Detection
from maris_common.yamlsrc import ConfigError, ConfigIssue, Mark
from vision.detector import DetectorConfig
from vision.occlusion import ArmShape
from vision.overlay import jpeg_preview, overlay_primitives
from vision.pipeline import PipePoseEstimator
from vision.silhouette import HsvRange
from vision.tracking import DetectionTracker, TrackerConfig

from .geometry import norm
from .render import Scene, StereoRenderer
from .render_optics import CameraResponse, WaterOptics
from .rng import child_rng
from .schema_render import VISION_MODELS
from .sensors import in_intervals
from .vision_calibration import VisionErrors, rig_calibration

if TYPE_CHECKING:  # the backend imports this module: its type only
    from vision.detector import PipeDetection

    from .backend import SimBackend


def _error(sim: SimBackend, key: str, message: str) -> ConfigError:
    return ConfigError([ConfigIssue(Mark(sim.scenario.source, 1, 1), tuple(key.split(".")), message)])


def check_model(sim: SimBackend) -> str:
    """The scenario's vision model name, checked."""
    name = sim.params["vision.model"]
    if name not in VISION_MODELS:
        raise _error(sim, "vision.model", f"unknown vision model `{name}`; known: {', '.join(VISION_MODELS)}")
    return name


class RenderedVision:
    """Same interface as :class:`sim_backend.vision.VisionModel` (``due``, ``capture``,
    ``publish``, ``latest``, ``last_view``, ``dropouts``), plus ``camera_frames``."""

    def __init__(self, params: dict, sim: SimBackend, errors: VisionErrors | None = None):
        self._sim = sim
        #: the run's systematic errors: the detector works with their believed calibration
        self.errors = errors
        self.period = 1.0 / float(params["vision.rate_hz"])
        self.latency = float(params["vision.latency_s"])
        self.turbidity = sim.turbidity
        self.dropouts: list[tuple[float, float]] = list(params["vision.dropouts"])
        calib = rig_calibration(params)
        vis = float(params["vision.water_visibility_m"][self.turbidity])
        optics = WaterOptics.for_visibility(
            vis,
            daylight=float(params["vision.daylight"]),
            lamp_power=float(params["vision.lamp_power"]),
            caustics=float(params["vision.caustics"]),
        )
        self.renderer = StereoRenderer(
            calib,
            optics,
            child_rng(sim.seed, "vision_render"),
            CameraResponse.for_water(optics, floor_depth_m=float(sim.pool_size[2])),
        )
        hue_lo, hue_hi = (int(round(x)) for x in params["vision.hsv_hue"])
        hue = (hue_lo, hue_hi)
        config = DetectorConfig(
            hsv=HsvRange(
                hue=hue,
                sat_min=int(round(params["vision.hsv_sat_min"])),
                val_min=int(round(params["vision.hsv_val_min"])),
            ),
            pipe_radius_m=float(params["pipe.radius_m"]),
            pipe_length_m=float(params["pipe.length_m"]),
            grasp_from_end_m=0.5 * float(params["pipe.length_m"]) + float(params["pipe.grasp_offset_m"]),
            arm=ArmShape(link_radius=float(params["vision.occlusion_radius_m"]) + 0.01, hand_radius=0.11),
        )
        errs = config.check()
        if errs:
            raise _error(sim, "vision.hsv_hue", "; ".join(errs))
        self.estimator = PipePoseEstimator(calib if errors is None else errors.stereo.believed, config, sim.model)
        self.arm_radius = float(params["vision.occlusion_radius_m"])
        self.log_period = 1.0 / float(params["vision.log_frames_hz"]) if params["vision.log_frames_hz"] > 0 else np.inf
        self.next_t = 0.0
        #: the detections go through the same tracker as on the vehicle (world frame of the navigation)
        dvl = bool(params["dvl.present"])  # without one, the navigation drifts faster: a looser track
        self.tracker = DetectionTracker(
            TrackerConfig() if dvl else TrackerConfig(position_walk_m_per_sqrt_s=0.02, angle_walk_rad_per_sqrt_s=0.005)
        )
        #: frames with the pipe in either view, frames where the detector found it, tracked
        #: detections published, detections the tracker rejected
        self.stats = {"frames_in_view": 0, "frames_found": 0, "published": 0, "rejected": 0}
        #: captured detections not yet published (oldest first)
        self.pending: deque[Detection] = deque()
        self._latest: Detection | None = None
        self._last_image: tuple[float, np.ndarray, PipeDetection | None] | None = None
        self._next_log_t = 0.0
        self.last_view: dict = {
            "in_view": False,
            "range_m": None,
            "occluded": False,
            "detected": False,
            "confidence": 0.0,
        }

    def due(self, t: float) -> bool:
        return t + 1e-12 >= self.next_t

    def capture(
        self,
        t: float,
        world_T_vehicle: np.ndarray,
        world_T_camera: np.ndarray,
        world_T_grasp: np.ndarray,
        arm_points_world: np.ndarray,
    ) -> None:
        """Render and detect the image pair of time ``t`` (s); poses (4, 4) world."""
        self.next_t += self.period
        if self.next_t <= t:
            self.next_t = t + self.period
        sim = self._sim
        pipe = sim.pipe_centre_pose()
        scene = Scene(
            tuple(sim.pool_size), pipe, sim.pipe.length, sim.pipe.radius, arm_points_world, self.arm_radius, 0.10, t
        )
        cam_T_world = np.linalg.inv(world_T_camera)
        target = cam_T_world[:3, :3] @ world_T_grasp[:3, 3] + cam_T_world[:3, 3]
        view = {
            "in_view": bool(target[2] > 0),
            "range_m": norm(target),
            "occluded": False,
            "confidence": 0.0,
            "reason": "",
            "detected": False,
            "rendered": True,
        }
        if not self.renderer.pipe_in_view(scene, world_T_camera):
            # Nothing pipe-coloured can be in the images (the bare pool gives the detector
            # nothing: tests/vision check it), so skip the work; render only for the log.
            view.update(in_view=False, rendered=False, reason="pipe outside both fields of view")
            self.last_view = view
            if t + 1e-9 >= self._next_log_t:
                self._last_image = (t, self.renderer.render(scene, world_T_camera)[0], None)
            return
        left, right = self.renderer.render(scene, world_T_camera)
        nav_att = sim.ahrs.attitude.copy() if sim.ahrs.t is not None else None
        q = sim.arm.q.copy()  # the encoders (their 0.1 mrad noise is negligible for the mask)
        det = self.estimator.estimate(left, right, attitude_rpy=nav_att, q=q)
        view.update(confidence=det.confidence, reason=det.reason)
        if det.found and det.vehicle_T_grasp is not None and self.errors is not None:
            vTc = np.linalg.inv(world_T_vehicle) @ world_T_camera
            det.vehicle_T_grasp = self.errors.correct_detection(vTc, det.vehicle_T_grasp)
        if det.found and det.vehicle_T_grasp is not None:
            truth_v = np.linalg.inv(world_T_vehicle) @ world_T_grasp
            view["position_error_m"] = norm(det.vehicle_T_grasp[:3, 3] - truth_v[:3, 3])
            c = abs(float(det.vehicle_T_grasp[:3, 0] @ truth_v[:3, 0]))
            view["axis_error_rad"] = float(np.arccos(min(1.0, c)))
        self._last_image = (t, left, det)
        self.stats["frames_in_view"] += 1
        if det.found:
            self.stats["frames_found"] += 1
        if det.found and det.vehicle_T_grasp is not None and not in_intervals(t, self.dropouts):
            view["detected"] = True
            wTv_nav = _nav_pose(sim)
            if self.tracker.add(t, det, wTv_nav):
                tp = self.tracker.output(t)
                if tp is not None:
                    details = _details(det)
                    details["tracker"] = tp.info
                    self.pending.append(
                        Detection(t=tp.t, pose=tp.vehicle_T_grasp, confidence=tp.confidence, details=details)
                    )
                    self.stats["published"] += 1
            else:
                self.stats["rejected"] += 1
        self.last_view = view

    def publish(self, t: float) -> None:
        while self.pending and self.pending[0].t + self.latency <= t + 1e-12:
            self._latest = self.pending.popleft()

    def latest(self) -> Detection | None:
        return self._latest

    def camera_frames(self) -> list[CameraFrame]:
        """The last left image as a downscaled JPEG with the detection drawn, at most
        every ``1 / vision.log_frames_hz`` s of image time."""

        if self._last_image is None or self._last_image[0] + 1e-9 < self._next_log_t:
            return []
        t, left, det = self._last_image
        self._next_log_t = t + self.log_period
        jpeg, w, h, scale = jpeg_preview(left)
        overlay = overlay_primitives(det, self.renderer.calib, scale) if det is not None else None
        return [CameraFrame(t, "left", jpeg, w, h, "stereo_camera", overlay)]


def _nav_pose(sim: SimBackend) -> np.ndarray:
    """The vehicle's world pose (4, 4) by its navigation (AHRS attitude, navigation position)."""
    from kcl.rotations import pose_matrix

    return pose_matrix(np.concatenate([np.asarray(sim.ahrs.position, float), np.asarray(sim.ahrs.attitude, float)]))


def _details(det) -> dict:
    """The JSON-able part of a detection worth logging."""
    d = det.to_dict()
    return {k: d[k] for k in ("confidence", "reason", "cam_T_grasp", "end_cam", "radius_m", "quality", "elapsed_ms")}
