"""Tracking the grasp frame over detections: outlier gating, an intermittent end, coasting.

MARIS filtered the target frame over time: a one-frame wrong detection must not
move the grasp frame, and the pipe end (which fixes the position along the
axis) is often seen in one frame only out of several. :class:`GraspTracker`
keeps, in a frame ``F`` that does not move with the vehicle (the world through
the navigation, or the vehicle frame itself when there is no navigation):

* the axis direction ``a`` (unit vector, variance ``var_a``, rad^2),
* the grasp point ``g`` with one variance across the axis (``var_lat``, m^2)
  and one along it (``var_along``, m^2),

and updates them from each detection with a scalar Kalman filter per part
(random-walk process noise between images). A detection counts as

* **axis**: direction and the grasp point's offset across the axis (every
  detection with a confidence);
* **end**: the grasp point's position along the axis, only when the detector
  saw a pipe end (without one, the detector guesses it from the region's
  centroid: that guess is ignored).

Gating: an innovation larger than ``gate_sigmas`` standard deviations of its
prediction (plus a floor for the detector's own systematic error) rejects the
detection whole (a wrong detection is usually wrong in every part). After
``reacquire_after`` rejected detections that agree with one another, the
track restarts from them (the pipe moved, or the first lock was wrong).

Output (:meth:`GraspTracker.estimate`): the filtered pose at the time of the
last accepted detection, its confidence, and the ages of the last accepted
axis and end measurements. The confidence is that of the accepted detections
that saw an end, as long as an end was seen within ``end_hold_s``; then the
detector's own (lower) no-end confidence; both fall once the track coasts
(no accepted detection for ``coast_s``, then halving every ``half_life_s``).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np


@dataclass(frozen=True)
class TrackerConfig:
    """Tracker settings (metres, radians, seconds)."""

    #: innovations beyond this many standard deviations reject a detection
    gate_sigmas: float = 4.0
    #: floors of the gate: the detector's systematic error, which filtering does not remove
    gate_floor_m: float = 0.03
    gate_floor_rad: float = 0.05
    #: consecutive rejected, mutually consistent detections after which the track restarts from them
    reacquire_after: int = 5
    #: random walk of the target in the tracking frame (navigation drift, the pipe drifting)
    position_walk_m_per_sqrt_s: float = 0.002
    angle_walk_rad_per_sqrt_s: float = 0.003
    #: measurement noise floors (a detection's own figure is used when larger)
    min_position_sigma_m: float = 0.003
    min_angle_sigma_rad: float = 0.004
    #: the end's position is held this long after it was last seen
    end_hold_s: float = 1.5
    #: coasting: the confidence starts to fall this long after the last accepted detection ...
    coast_s: float = 0.3
    #: ... and halves every this many seconds
    half_life_s: float = 0.5

    def check(self) -> list[str]:
        """Problems with the settings (empty when usable)."""
        errs = []
        for name in ("gate_sigmas", "end_hold_s", "half_life_s"):
            if not getattr(self, name) > 0:
                errs.append(f"tracker {name} must be positive, got {getattr(self, name)}")
        if self.reacquire_after < 1:
            errs.append(f"tracker reacquire_after must be >= 1, got {self.reacquire_after}")
        return errs


@dataclass(frozen=True)
class Measurement:
    """One detection in the tracking frame: time (s, image time), grasp frame pose
    (4, 4; x along the axis), whether an end was seen, the detector's confidence,
    its expected position error (m) and axis error (rad)."""

    t: float
    pose: np.ndarray
    end_seen: bool
    confidence: float
    sigma_m: float = 0.005
    sigma_rad: float = 0.01


@dataclass
class TrackState:
    """The filter's state; see the module doc."""

    t: float
    a: np.ndarray
    g: np.ndarray
    rot: np.ndarray
    var_a: float
    var_lat: float
    var_along: float
    t_axis: float
    t_end: float | None
    conf_end: float
    conf_no_end: float


@dataclass(frozen=True)
class TrackEstimate:
    """The tracker's answer: the grasp frame (4, 4, tracking frame) at time ``t``
    (the last accepted detection's image time), its confidence, why it is what it is."""

    t: float
    pose: np.ndarray
    confidence: float
    state: str
    axis_age_s: float
    end_age_s: float | None
    accepted: int
    rejected: int

    def to_dict(self) -> dict:
        return {
            "state": self.state,
            "axis_age_s": round(self.axis_age_s, 3),
            "end_age_s": None if self.end_age_s is None else round(self.end_age_s, 3),
            "accepted": self.accepted,
            "rejected": self.rejected,
        }


@dataclass
class GraspTracker:
    """The filter (see the module doc). ``update`` with each detection, ``estimate`` any time."""

    config: TrackerConfig = TrackerConfig()
    state: TrackState | None = None
    accepted: int = 0
    rejected: int = 0
    last_decision: str = ""
    _pending: list[Measurement] = field(default_factory=list)

    def reset(self) -> None:
        self.state = None
        self._pending.clear()

    def update(self, m: Measurement) -> bool:
        """Take one detection; True if it was accepted."""
        if not (np.all(np.isfinite(m.pose)) and np.isfinite(m.confidence)) or m.confidence <= 0.0:
            self.last_decision = "ignored: no usable detection"
            return False
        if self.state is None:
            self._start(m)
            self.last_decision = "started"
            return True
        s = self.state
        cfg = self.config
        dt = max(m.t - s.t, 0.0)
        var_a = s.var_a + cfg.angle_walk_rad_per_sqrt_s**2 * dt
        var_lat = s.var_lat + cfg.position_walk_m_per_sqrt_s**2 * dt
        var_along = s.var_along + cfg.position_walk_m_per_sqrt_s**2 * dt
        a_m = _unit(m.pose[:3, 0])
        if a_m @ s.a < 0:
            a_m = -a_m
        r_a = max(m.sigma_rad, cfg.min_angle_sigma_rad) ** 2
        r_p = max(m.sigma_m, cfg.min_position_sigma_m) ** 2
        ang = float(np.arccos(np.clip(a_m @ s.a, -1.0, 1.0)))
        d = m.pose[:3, 3] - s.g
        along = float(d @ s.a)
        lat = float(np.linalg.norm(d - along * s.a))
        k = cfg.gate_sigmas
        ok = (
            ang <= k * np.sqrt(var_a + r_a) + cfg.gate_floor_rad
            and lat <= k * np.sqrt(var_lat + r_p) + cfg.gate_floor_m
        )
        if ok and m.end_seen and s.t_end is not None:
            ok = abs(along) <= k * np.sqrt(var_along + r_p) + cfg.gate_floor_m
        if not ok:
            self.rejected += 1
            self.last_decision = (
                f"rejected: {np.degrees(ang):.1f} deg, {100 * lat:.1f} cm across, {100 * abs(along):.1f} cm along"
            )
            self._pending.append(m)
            if self._consistent_pending():
                self._start(self._pending[-1])
                self.last_decision = f"restarted from {len(self._pending)} consistent detections"
                self._pending.clear()
                return True
            return False
        self._pending.clear()
        self.accepted += 1
        # axis direction
        ka = var_a / (var_a + r_a)
        a = _unit(s.a + ka * (a_m - s.a))
        var_a = (1.0 - ka) * var_a
        # grasp point across the axis (measured relative to the old axis, then kept on the new one)
        kl = var_lat / (var_lat + r_p)
        g = s.g + kl * (d - along * s.a)
        var_lat = (1.0 - kl) * var_lat
        t_end = s.t_end
        if m.end_seen:
            kal = var_along / (var_along + r_p) if s.t_end is not None else 1.0
            g = g + kal * along * s.a
            var_along = (1.0 - kal) * var_along if s.t_end is not None else r_p
            t_end = m.t
            conf_end = m.confidence if s.t_end is None else 0.7 * s.conf_end + 0.3 * m.confidence
            conf_no_end = s.conf_no_end
        else:
            conf_end = s.conf_end
            conf_no_end = m.confidence
        self.state = TrackState(
            m.t, a, g, _frame(a, m.pose), var_a, var_lat, var_along, m.t, t_end, conf_end, conf_no_end
        )
        self.last_decision = "accepted"
        return True

    def estimate(self, now: float) -> TrackEstimate | None:
        """The filtered grasp frame, its confidence at time ``now`` (s), and the track's state."""
        s = self.state
        if s is None:
            return None
        cfg = self.config
        axis_age = max(now - s.t_axis, 0.0)
        end_age = None if s.t_end is None else max(now - s.t_end, 0.0)
        if end_age is not None and end_age <= cfg.end_hold_s:
            conf, what = s.conf_end, "tracking"
        else:
            conf, what = s.conf_no_end, "no recent end"
        if axis_age > cfg.coast_s:
            conf *= 0.5 ** ((axis_age - cfg.coast_s) / cfg.half_life_s)
            what = "coasting"
        pose = np.eye(4)
        pose[:3, :3], pose[:3, 3] = s.rot, s.g
        return TrackEstimate(s.t, pose, float(conf), what, axis_age, end_age, self.accepted, self.rejected)

    # ------------------------------------------------------------------ helpers

    def _start(self, m: Measurement) -> None:
        cfg = self.config
        r_p = max(m.sigma_m, cfg.min_position_sigma_m) ** 2
        a = _unit(m.pose[:3, 0])
        self.state = TrackState(
            m.t,
            a,
            m.pose[:3, 3].astype(float).copy(),
            _frame(a, m.pose),
            max(m.sigma_rad, cfg.min_angle_sigma_rad) ** 2,
            r_p,
            r_p if m.end_seen else 1.0,
            m.t,
            m.t if m.end_seen else None,
            m.confidence if m.end_seen else 0.0,
            m.confidence,
        )

    def _consistent_pending(self) -> bool:
        """The last ``reacquire_after`` rejected detections agree with one another."""
        cfg = self.config
        if len(self._pending) < cfg.reacquire_after:
            return False
        recent = self._pending[-cfg.reacquire_after :]
        ref = recent[-1]
        for m in recent[:-1]:
            ang = float(np.arccos(np.clip(abs(_unit(m.pose[:3, 0]) @ _unit(ref.pose[:3, 0])), -1.0, 1.0)))
            d = m.pose[:3, 3] - ref.pose[:3, 3]
            a = _unit(ref.pose[:3, 0])
            lat = float(np.linalg.norm(d - (d @ a) * a))
            if ang > 2.0 * cfg.gate_floor_rad or lat > 2.0 * cfg.gate_floor_m:
                return False
        return True


def _unit(v: np.ndarray) -> np.ndarray:
    return np.asarray(v, dtype=float) / float(np.linalg.norm(v))


def _frame(a: np.ndarray, pose: np.ndarray) -> np.ndarray:
    """Rotation with x along ``a`` and z as close as possible to the measured frame's z
    (gravity's direction across the axis, from the detector)."""
    z = pose[:3, 2] - (pose[:3, 2] @ a) * a
    n = float(np.linalg.norm(z))
    if n < 1e-9:
        z = np.cross(a, [1.0, 0.0, 0.0] if abs(a[0]) < 0.9 else [0.0, 1.0, 0.0])
        n = float(np.linalg.norm(z))
    z = z / n
    return np.column_stack([a, np.cross(z, a), z])


@dataclass(frozen=True)
class TrackedPose:
    """What a detector publishes from the track: image time ``t`` of the last accepted
    detection, the grasp frame in the vehicle frame at that time (``vehicle_T_grasp``),
    the confidence now, and the track's state for the log."""

    t: float
    vehicle_T_grasp: np.ndarray
    confidence: float
    info: dict


class DetectionTracker:
    """A :class:`GraspTracker` fed with detector outputs (:class:`vision.detector.PipeDetection`)
    and the vehicle's pose in the tracking frame at each image time
    (``frame_T_vehicle``: the navigation's world pose, or the identity to track in
    the vehicle frame). It answers in the vehicle frame of the last accepted image."""

    def __init__(self, config: TrackerConfig = TrackerConfig()):
        errs = config.check()
        if errs:
            raise ValueError("; ".join(errs))
        self.tracker = GraspTracker(config)
        self._frame_at: dict[float, np.ndarray] = {}

    def add(self, t: float, det: object, frame_T_vehicle: np.ndarray) -> bool:
        """Take the detection of the image of time ``t`` (s); True if the track accepted it."""
        vTg = getattr(det, "vehicle_T_grasp", None)
        if vTg is None or not getattr(det, "found", False):
            return False
        quality = getattr(det, "quality", {}) or {}
        sigma = float(quality.get("depth_sigma_m", 0.005))
        sigma_m = float(np.clip(sigma if np.isfinite(sigma) else 0.05, 0.003, 0.05))
        m = Measurement(
            t,
            np.asarray(frame_T_vehicle, float) @ np.asarray(vTg, float),
            getattr(det, "end_cam", None) is not None,
            float(getattr(det, "confidence", 0.0)),
            sigma_m,
            sigma_m / 0.5,
        )
        ok = self.tracker.update(m)
        if ok:
            self._frame_at[t] = np.asarray(frame_T_vehicle, float).copy()
            for old in [k for k in self._frame_at if k < t]:
                del self._frame_at[old]
        return ok

    def output(self, now: float) -> TrackedPose | None:
        """The tracked grasp frame and its confidence at time ``now`` (s), or None before any detection."""
        est = self.tracker.estimate(now)
        if est is None or est.t not in self._frame_at:
            return None
        vTg = np.linalg.inv(self._frame_at[est.t]) @ est.pose
        info = est.to_dict()
        info["last"] = self.tracker.last_decision
        return TrackedPose(est.t, vTg, est.confidence, info)
