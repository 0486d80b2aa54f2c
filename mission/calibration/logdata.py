"""What a run log measured, as arrays for :mod:`mission.calibration.fit`.

From the topics every run writes (``mission.logs.channels``): the commanded
body velocity (``/vehicle/command``, device log rate), the navigation
(``/vehicle/navigation``: DVL velocity with its ping time, gyro rates, pose),
the detections (``/detector``, one per image that saw the target) and the arm
joints (``/arm/state``, for the arm's occlusion of the camera). Times are
seconds since the run start. Several logs are concatenated with a gap, so
their samples never mix.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from mission.logs.reader import read_log

#: gap (s) put between consecutive logs
LOG_GAP_S = 1000.0


@dataclass
class LogData:
    """Arrays of one or several logs (see the module docstring)."""

    files: list[str] = field(default_factory=list)
    duration_s: float = 0.0
    t_cmd: np.ndarray = field(default_factory=lambda: np.zeros(0))
    cmd: np.ndarray = field(default_factory=lambda: np.zeros((0, 6)))
    t_dvl: np.ndarray = field(default_factory=lambda: np.zeros(0))  # distinct ping times
    dvl: np.ndarray = field(default_factory=lambda: np.zeros((0, 3)))
    segments_dvl: list[np.ndarray] = field(default_factory=list)  # ping times per log
    t_nav: np.ndarray = field(default_factory=lambda: np.zeros(0))
    position: np.ndarray = field(default_factory=lambda: np.zeros((0, 3)))
    attitude: np.ndarray = field(default_factory=lambda: np.zeros((0, 3)))
    t_gyro: np.ndarray = field(default_factory=lambda: np.zeros(0))
    gyro: np.ndarray = field(default_factory=lambda: np.zeros((0, 3)))
    t_det: np.ndarray = field(default_factory=lambda: np.zeros(0))  # image times
    det_pose: np.ndarray = field(default_factory=lambda: np.zeros((0, 4, 4)))  # vehicle frame
    t_arm: np.ndarray = field(default_factory=lambda: np.zeros(0))
    q: np.ndarray = field(default_factory=lambda: np.zeros((0, 0)))
    scenario_text: str | None = None
    scenario_name: str | None = None
    log_rate_hz: float = math.nan


def _rows(msgs: list[dict], key: str, width: int) -> tuple[np.ndarray, np.ndarray]:
    keep = [m for m in msgs if isinstance(m.get(key), list) and len(m[key]) >= width]
    t = np.array([m["t"] for m in keep], dtype=float)
    v = np.array([[np.nan if x is None else x for x in m[key][:width]] for m in keep], dtype=float).reshape(-1, width)
    return t, v


def read_logs(paths: Sequence[str | Path]) -> LogData:
    """Load and concatenate the logs (raises ``mission.logs.reader.LogError`` for unreadable files)."""

    out = LogData()
    parts: dict[str, list[np.ndarray]] = {
        k: []
        for k in (
            "t_cmd",
            "cmd",
            "t_dvl",
            "dvl",
            "t_nav",
            "position",
            "attitude",
            "t_gyro",
            "gyro",
            "t_det",
            "det_pose",
            "t_arm",
            "q",
        )
    }
    offset = 0.0
    rates = []
    for path in paths:
        log = read_log(path)
        out.files.append(str(path))
        t0 = log.t0
        shift = offset - t0
        cmd_msgs = log.messages("/vehicle/command")
        t, v = _rows(cmd_msgs, "body_velocity", 6)
        parts["t_cmd"].append(t + shift)
        parts["cmd"].append(v)
        nav = log.messages("/vehicle/navigation")
        t, pos = _rows(nav, "position", 3)
        _, att = _rows(nav, "attitude", 3)
        parts["t_nav"].append(t + shift)
        parts["position"].append(pos)
        parts["attitude"].append(att)
        if len(nav) > 2:
            rates.append(1.0 / float(np.median(np.diff([m["t"] for m in nav]))))
        with_v = [m for m in nav if isinstance(m.get("body_velocity"), list) and m.get("velocity_t") is not None]
        seen: dict[float, list] = {}
        for m in with_v:
            seen.setdefault(float(m["velocity_t"]), m["body_velocity"][:3])
        tp = np.array(sorted(seen), dtype=float)
        parts["t_dvl"].append(tp + shift)
        parts["dvl"].append(np.array([seen[k] for k in sorted(seen)], dtype=float).reshape(-1, 3))
        out.segments_dvl.append(tp + shift)
        tg, g = _rows([m for m in with_v if len(m["body_velocity"]) >= 6], "body_velocity", 6)
        parts["t_gyro"].append(tg + shift)
        parts["gyro"].append(g[:, 3:6])
        dets: dict[float, list] = {}
        for m in log.messages("/detector"):
            if m.get("image_t") is not None and isinstance(m.get("pose"), list) and len(m["pose"]) == 16:
                dets.setdefault(float(m["image_t"]), m["pose"])
        td = np.array(sorted(dets), dtype=float)
        parts["t_det"].append(td + shift)
        parts["det_pose"].append(np.array([dets[k] for k in sorted(dets)], dtype=float).reshape(-1, 4, 4))
        ta, q = _rows(
            log.messages("/arm/state"),
            "position",
            max(1, len((log.messages("/arm/state") or [{}])[0].get("position") or [])),
        )
        parts["t_arm"].append(ta + shift)
        parts["q"].append(q)
        for src in log.messages("/run/source"):
            if src.get("role") == "scenario" and out.scenario_text is None:
                out.scenario_text = src.get("text")
        cfg = log.messages("/run/config")
        if cfg and out.scenario_name is None:
            out.scenario_name = cfg[0].get("scenario")
        out.duration_s += log.end_time
        offset += log.end_time + LOG_GAP_S
    for k, chunks in parts.items():
        if chunks and any(c.size for c in chunks):
            non_empty = [c for c in chunks if c.size] or chunks[:1]
            setattr(out, k, np.concatenate(non_empty))
    out.log_rate_hz = float(np.median(rates)) if rates else math.nan
    return out
