"""Log channels of the vision system: camera frames for Foxglove's Image panel.

* ``/camera/left/compressed``: ``foxglove.CompressedImage`` (protobuf, the SDK's
  schema, like the other well-known channels of :mod:`mission.logs.wellknown`):
  the left camera's image, downscaled JPEG, ``timestamp`` = its image time,
  ``frame_id`` = the optical frame (``stereo_camera``).
* ``/vision/annotations``: ``foxglove.ImageAnnotations`` for that image: the
  straight edges, the fitted axis, the grasp frame's axes, the visible end and
  the confidence (tick it in the Image panel's annotations list).
* ``/vision/detection``: ``maris.VisionDetection`` (JSON), each new detection
  with what the detector saw: camera-frame pose, visible pipe end, quality.

Images come only from detectors that render or grab them (the stereo pipe
detector driver, the simulator's rendered vision), at their ``log_frames_hz``.
"""

from __future__ import annotations

from typing import Any

from foxglove import messages as fm

_NUM = {"type": "number"}
_VEC = {"type": "array", "items": {"type": "number"}}

VISION_DETECTION = {
    "title": "VisionDetection",
    "description": "A detection of the stereo pipe detector: grasp frame in the vehicle frame (vTg) and the "
    "left camera frame (cTg), 4x4 row major; visible pipe end in the camera frame (m); quality.",
    "type": "object",
    "properties": {
        "t": {"type": "number", "description": "backend clock, s"},
        "image_t": {"type": "number", "description": "image time, s"},
        "confidence": _NUM,
        "reason": {"type": "string", "description": "why the confidence is below 1 (empty when nothing is off)"},
        "vehicle_T_grasp": _VEC,
        "cam_T_grasp": _VEC,
        "end_cam": _VEC,
        "radius_m": _NUM,
        "elapsed_ms": {"type": "number", "description": "detector's cost for this pair, ms"},
        "quality": {
            "type": "object",
            "properties": {"range_m": _NUM, "plane_rms_px": _NUM, "depth_sigma_m": _NUM, "length_m": _NUM},
        },
    },
    "required": ["t", "image_t", "confidence"],
}

#: JSON channels, merged into :data:`mission.logs.channels.CHANNELS`.
VISION_CHANNELS: dict[str, tuple[str, dict]] = {"/vision/detection": ("maris.VisionDetection", VISION_DETECTION)}

#: Protobuf (foxglove-sdk) channels; listed in :data:`mission.logs.wellknown.WELL_KNOWN` too.
VISION_WELL_KNOWN: dict[str, type] = {
    "/camera/left/compressed": fm.CompressedImage,
    "/vision/annotations": fm.ImageAnnotations,
}


def _ts(ns: int) -> fm.Timestamp:
    return fm.Timestamp(sec=ns // 1_000_000_000, nsec=ns % 1_000_000_000)


def _color(c: Any) -> fm.Color:
    r, g, b, a = (float(x) for x in c)
    return fm.Color(r=r, g=g, b=b, a=a)


def image_message(frame: Any, ns: int) -> fm.CompressedImage:
    """``foxglove.CompressedImage`` of a :class:`hal.interfaces.CameraFrame` taken at log time ``ns``."""
    return fm.CompressedImage(timestamp=_ts(ns), frame_id=frame.frame_id, data=bytes(frame.jpeg), format="jpeg")


def annotations_message(frame: Any, ns: int) -> fm.ImageAnnotations:
    """``foxglove.ImageAnnotations`` of a frame's overlay. The overlay uses pixel
    centres ((0, 0) = centre of the top-left pixel); Foxglove the top-left corner: +0.5."""
    ts = _ts(ns)
    ov = frame.overlay or {}
    pt = lambda p: fm.Point2(x=float(p[0]) + 0.5, y=float(p[1]) + 0.5)  # noqa: E731
    clear = fm.Color(r=0.0, g=0.0, b=0.0, a=0.0)
    points = [
        fm.PointsAnnotation(
            timestamp=ts,
            type=fm.PointsAnnotationType.LineStrip,
            points=[pt(p) for p in ln["points"]],
            outline_color=_color(ln["color"]),
            outline_colors=[],
            fill_color=clear,
            thickness=float(ln.get("thickness", 1.0)),
        )
        for ln in ov.get("lines", [])
    ]
    circles = [
        fm.CircleAnnotation(
            timestamp=ts,
            position=pt(c["position"]),
            diameter=float(c["diameter"]),
            thickness=2.0,
            fill_color=clear,
            outline_color=_color(c["color"]),
        )
        for c in ov.get("circles", [])
    ]
    texts = [
        fm.TextAnnotation(
            timestamp=ts,
            position=pt(x["position"]),
            text=str(x["text"]),
            font_size=12.0,
            text_color=_color(x["color"]),
            background_color=fm.Color(r=0.0, g=0.0, b=0.0, a=0.5),
        )
        for x in ov.get("texts", [])
    ]
    return fm.ImageAnnotations(circles=circles, points=points, texts=texts)


def detection_message(det: Any) -> dict | None:
    """``maris.VisionDetection`` of a :class:`hal.interfaces.Detection` with ``details`` (None without)."""
    d = getattr(det, "details", None)
    if not d:
        return None
    flat = lambda m: [float(x) for row in m for x in row] if m is not None else []  # noqa: E731
    q = d.get("quality") or {}
    return {
        "image_t": float(det.t),
        "confidence": float(det.confidence),
        "reason": str(d.get("reason") or ""),
        "vehicle_T_grasp": [float(x) for x in det.pose.reshape(-1)],
        "cam_T_grasp": flat(d.get("cam_T_grasp")),
        "end_cam": [float(x) for x in (d.get("end_cam") or [])],
        "radius_m": float(d.get("radius_m") or 0.0),
        "elapsed_ms": float(d.get("elapsed_ms") or 0.0),
        "quality": {
            k: float(q[k]) for k in ("range_m", "plane_rms_px", "depth_sigma_m", "length_m") if q.get(k) is not None
        },
    }


def write_detection(log: Any, t: float, det: Any) -> None:
    """Log a new detection's details on ``/vision/detection`` (nothing for simple models)."""
    msg = detection_message(det)
    if msg is not None:
        log.write("/vision/detection", t, msg)


def write_frames(log: Any, t: float, detector: Any) -> None:
    """Log the detector's new camera frames (at loop time ``t``, stamped with their
    image time) and their annotations."""
    frames = getattr(detector, "camera_frames", None)
    write = getattr(log, "write_message", None)
    for frame in frames() if frames is not None else ():
        topic = f"/camera/{frame.camera}/compressed"
        if write is None or topic not in VISION_WELL_KNOWN:
            continue
        ns = log.log_time_ns(frame.t)
        write(topic, log.log_time_ns(t), image_message(frame, ns))
        if frame.overlay is not None:
            write("/vision/annotations", log.log_time_ns(t), annotations_message(frame, ns))
