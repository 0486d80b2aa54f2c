"""``maris calibrate``: fit the simulator parameters a set of run logs determines.

What a log can determine, and how (:mod:`mission.calibration.fit`):

* the vehicle's velocity response, per DOF with enough excitation: commanded
  body velocity (``/vehicle/command``) vs the DVL pings (u, v, w) and the gyro
  (p, q, r) -> the first-order model (``vehicle.model: first_order``): time
  constant, dead band, low-speed gain and scale, and the unmodelled
  disturbance (std, correlation time). The full model's hydrodynamics, thrust
  curve and DCL gains are *not* separable from these signals (no thrust or
  force is logged), so a calibrated scenario uses the first-order model;
* DVL rate, lost pings and noise (second differences of consecutive pings);
* gyro white noise (second differences of the logged rates). The rates are in
  the navigation's ``body_velocity``, which the HAL fills only with a DVL; the
  log rate (20 Hz by default) hides a vibration line above 10 Hz (aliased);
* detections: the share of camera images with a detection while the target was
  in the field of view and not hidden by the arm, and the farthest range of a
  detection (visibility), for one turbidity level. The target's world position
  is the median of the detections placed with the navigation.

Everything not determined keeps the base scenario's value. The result is a
scenario file (``extends:`` the base) with each fitted value, its one-sigma
uncertainty and its sample count in a comment beside it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from kcl.model import UvmsModel
from kcl.rotations import rpy_to_matrix
from mission.calibration.fit import (
    Fit,
    ResponseFit,
    detection_rate,
    fit_velocity_response,
    sample_rate,
    white_noise_std,
)
from mission.calibration.logdata import LogData
from sim_backend import load_scenario
from sim_backend.geometry import inverse_pose
from sim_backend.vision import in_field_of_view, occluded

DOFS = ("u", "v", "w", "p", "q", "r")
#: a DOF needs commands with at least this std (m/s, rad/s) to fit its response
MIN_EXCITATION = 0.01


@dataclass
class Calibration:
    """Fits from the logs; ``response[i]`` is None when DOF ``i`` was not fitted (why in ``skipped``)."""

    data: LogData
    base: str
    turbidity: str
    response: list[ResponseFit | None] = field(default_factory=lambda: [None] * 6)
    skipped: dict[str, str] = field(default_factory=dict)
    dvl_rate: Fit | None = None
    dvl_loss: Fit | None = None
    dvl_noise: Fit | None = None
    gyro_noise: Fit | None = None
    p_detect: Fit | None = None
    visibility: Fit | None = None
    detection_bins: list[tuple[float, int, int]] = field(default_factory=list)


def calibrate(data: LogData, base: str = "pool_clear", turbidity: str = "clear") -> Calibration:
    """Fit everything the logs determine (see the module docstring)."""
    cal = Calibration(data, base, turbidity)
    if data.t_dvl.size >= 3:
        per_log = [sample_rate(seg) for seg in data.segments_dvl if seg.size >= 3]
        rates, losses = [r for r, _ in per_log], [lost for _, lost in per_log]
        n = sum(lost.n for lost in losses)
        p = sum(lost.value * lost.n for lost in losses) / n
        cal.dvl_rate = Fit(
            float(np.median([r.value for r in rates])), max(r.sigma for r in rates), sum(r.n for r in rates)
        )
        cal.dvl_loss = Fit(p, math.sqrt(max(p * (1 - p), 1.0 / n) / n), n)
        cal.dvl_noise = _pooled([white_noise_std(data.dvl[:, i]) for i in range(3)])
    if data.t_gyro.size >= 8:
        cal.gyro_noise = _pooled([white_noise_std(data.gyro[:, i]) for i in range(3)])
    for i, name in enumerate(DOFS):
        if i < 3:
            t_meas, y, noise = data.t_dvl, data.dvl[:, i] if data.dvl.size else np.zeros(0), cal.dvl_noise
        else:
            t_meas, y, noise = data.t_gyro, data.gyro[:, i - 3] if data.gyro.size else np.zeros(0), cal.gyro_noise
        if t_meas.size < 20:
            cal.skipped[name] = "no measurement of this velocity in the logs" + (
                " (no DVL)" if i < 3 else " (rates are logged only with a DVL)"
            )
            continue
        c = data.cmd[:, i]
        if data.t_cmd.size < 20 or float(np.std(c)) < MIN_EXCITATION:
            cal.skipped[name] = "commands too small to excite it"
            continue
        cal.response[i] = fit_velocity_response(data.t_cmd, c, t_meas, y, noise.value if noise else 0.0)
    _fit_detection(cal)
    return cal


def _pooled(fits: list[Fit]) -> Fit:
    ok = [f for f in fits if math.isfinite(f.value)]
    if not ok:
        return fits[0]
    n = sum(f.n for f in ok)
    v = math.sqrt(sum(f.value**2 * f.n for f in ok) / n)
    return Fit(v, v * 1.1 / math.sqrt(n), n, "pooled over the 3 axes")


def _interp_pose(data: LogData, t: np.ndarray) -> np.ndarray:
    """World poses (k, 4, 4) of the vehicle at times ``t`` from the navigation."""

    pos = np.column_stack([np.interp(t, data.t_nav, data.position[:, j]) for j in range(3)])
    att = np.column_stack([np.interp(t, data.t_nav, np.unwrap(data.attitude[:, j])) for j in range(3)])
    out = np.tile(np.eye(4), (len(t), 1, 1))
    for k in range(len(t)):
        out[k, :3, :3] = rpy_to_matrix(*att[k])
        out[k, :3, 3] = pos[k]
    return out


def _fit_detection(cal: Calibration) -> None:
    data = cal.data
    if data.t_det.size < 2 or data.t_nav.size < 2:
        cal.p_detect = Fit(math.nan, math.nan, int(data.t_det.size), "fewer than 2 detections")
        return

    params: dict[str, Any] = dict(load_scenario(cal.base).values)
    model = UvmsModel.load()
    dt = np.diff(data.t_det)
    period = float(np.median(dt[dt < 1.5 * dt.min()])) if dt.size else math.nan
    poses = _interp_pose(data, data.t_det)
    target_world = np.median(np.einsum("kij,kjl->kil", poses, data.det_pose)[:, :3, 3], axis=0)
    frames = tuple(model.joint_names) + ("tool",)
    q0 = model.neutral()

    def view(t_img: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        wTv = _interp_pose(data, t_img)
        ranges, usable = np.zeros(len(t_img)), np.zeros(len(t_img), dtype=bool)
        for k, t in enumerate(t_img):
            q = (
                q0
                if data.t_arm.size == 0
                else np.array([np.interp(t, data.t_arm, data.q[:, j]) for j in range(data.q.shape[1])])
            )
            vTc = model.frame_pose_vehicle(q, "stereo_camera")
            cTw = inverse_pose(wTv[k] @ vTc)
            p_cam = cTw[:3, :3] @ target_world + cTw[:3, 3]
            arm = np.array([model.frame_pose_vehicle(q, f)[:3, 3] for f in frames])
            arm_cam = (inverse_pose(vTc)[:3, :3] @ arm.T).T + inverse_pose(vTc)[:3, 3]
            ranges[k] = float(np.linalg.norm(p_cam))
            usable[k] = (
                in_field_of_view(p_cam, params["vision.fov_h_rad"], params["vision.fov_v_rad"])
                and ranges[k] >= params["vision.min_range_m"]
                and not occluded(p_cam, arm_cam, params["vision.occlusion_radius_m"])
            )
        return ranges, usable

    images = np.concatenate([np.arange(seg_start, seg_end, period) for seg_start, seg_end in _segments(data)])
    r_img, ok_img = view(images)
    r_det, ok_det = view(data.t_det)
    cal.p_detect, cal.visibility, cal.detection_bins = detection_rate(period, r_img[ok_img], r_det[ok_det])


def _segments(data: LogData) -> list[tuple[float, float]]:
    """(start, end) of each log's navigation, s."""
    t = data.t_nav
    cuts = np.flatnonzero(np.diff(t) > 10.0)
    starts = np.concatenate([[t[0]], t[cuts + 1]])
    ends = np.concatenate([t[cuts], [t[-1]]])
    return list(zip(starts.tolist(), ends.tolist()))
