"""What the pipe-detector drivers share: the vehicle's state at an image's time
(attitude for gravity, joint angles for the arm mask, the world pose for
tracking) and the track their :meth:`latest` publishes.

:func:`image_context` reads the vehicle and arm drivers; :class:`PipeTrack`
passes each detection through :class:`vision.tracking.DetectionTracker`, in the
world frame of the navigation (tuned for a DVL-aided one, or one without a
DVL), or in the vehicle frame without a navigation position, and turns the
track into a HAL :class:`~hal.interfaces.Detection` (see
:mod:`hal.drivers.pipe_detector` for what the track does).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from hal.interfaces import Arm, Detection, Vehicle
from kcl.model import UvmsModel
from kcl.rotations import pose_matrix
from vision.tracking import DetectionTracker, TrackerConfig

#: Tracking in the navigation's world frame: the pipe stays put, a DVL-aided navigation drifts slowly ...
WORLD_TRACKING = TrackerConfig()
#: ... and one without a DVL (dead reckoning on the commanded velocity) drifts cm in seconds.
WORLD_TRACKING_NO_DVL = TrackerConfig(position_walk_m_per_sqrt_s=0.02, angle_walk_rad_per_sqrt_s=0.005)
#: Tracking in the vehicle frame (no navigation): the vehicle's own motion moves the target.
VEHICLE_TRACKING = TrackerConfig(position_walk_m_per_sqrt_s=0.05, angle_walk_rad_per_sqrt_s=0.05)
TRACKING = {"world": WORLD_TRACKING, "world, no DVL": WORLD_TRACKING_NO_DVL, "vehicle": VEHICLE_TRACKING}
#: Fields of a detection kept in the published ``details``.
DETAIL_KEYS = ("confidence", "reason", "cam_T_grasp", "end_cam", "radius_m", "quality", "elapsed_ms")


@dataclass
class ImageContext:
    """The vehicle's state at an image's time: attitude (rad) and joint angles
    (rad), None when unknown; the world pose (4, 4), None without a navigation
    position; whether the navigation has a DVL; a warning (e.g. an arm that does
    not match the model: no arm mask then)."""

    attitude: np.ndarray | None
    q: np.ndarray | None
    world_T_vehicle: np.ndarray | None
    nav_dvl: bool
    warning: str = ""


def image_context(vehicle: Vehicle | None, arm: Arm | None, model: UvmsModel | None) -> ImageContext:
    """Read the vehicle's attitude and pose and the arm's joint angles now."""
    att = q = world_T_vehicle = None
    nav_dvl, warning = True, ""
    if vehicle is not None:
        try:
            nav = vehicle.navigation()
            att = np.asarray(nav.attitude, dtype=float)
            nav_dvl = getattr(nav, "body_velocity", None) is not None
            pos = np.asarray(getattr(nav, "position", np.full(3, np.nan)), dtype=float)
            if att.shape == (3,) and pos.shape == (3,) and np.all(np.isfinite(att)) and np.all(np.isfinite(pos)):
                world_T_vehicle = pose_matrix(np.concatenate([pos, att]))
        except Exception:  # noqa: BLE001 - no attitude: gravity from the image instead
            att = None
    if arm is not None:
        try:
            q = np.asarray(arm.joint_state().position, dtype=float)
        except Exception:  # noqa: BLE001 - no joint angles: no arm mask
            q = None
        if q is not None and model is not None and q.shape != (model.n_joints,):
            warning = (
                f"arm mask off: the arm reports {q.size} joint(s), the URDF {Path(model.urdf_path).name} has "
                f"{model.n_joints}; set `urdf` to your arm's model"
            )
            q = None
    return ImageContext(att, q, world_T_vehicle, nav_dvl, warning)


class PipeTrack:
    """The tracked pipe (not thread-safe: the driver holds its lock around it)."""

    def __init__(self) -> None:
        self.tracker = DetectionTracker(WORLD_TRACKING)
        self.frame = "world"
        self.details: dict = {}

    def add(self, t: float, det: Any, ctx: ImageContext) -> None:
        """A detection (:class:`vision.detector.PipeDetection` with a pose) of image time ``t``."""
        frame = "vehicle" if ctx.world_T_vehicle is None else ("world" if ctx.nav_dvl else "world, no DVL")
        if frame != self.frame:  # the navigation changed: a new track in the other frame
            self.tracker = DetectionTracker(TRACKING[frame])
            self.frame = frame
        pose = ctx.world_T_vehicle if ctx.world_T_vehicle is not None else np.eye(4)
        if self.tracker.add(t, det, pose):
            d = det.to_dict()
            self.details = {k: d[k] for k in DETAIL_KEYS}

    def output(self, now: float) -> Detection | None:
        """The track as a HAL detection at time ``now`` (None before the first)."""
        tp = self.tracker.output(now)
        if tp is None:
            return None
        details = dict(self.details)
        details["tracker"] = {**tp.info, "frame": self.frame}
        return Detection(t=tp.t, pose=tp.vehicle_T_grasp, confidence=tp.confidence, details=details)
