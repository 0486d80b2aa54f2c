"""Log channels of the vision system, shaped for Foxglove's Image panel.

* ``/camera/left/compressed``: ``foxglove.CompressedImage`` (JSON encoding: the
  JPEG bytes base64 in ``data``, ``format: "jpeg"``, ``timestamp`` = image time).
* ``/vision/annotations``: ``foxglove.ImageAnnotations`` for that image: the
  straight edges, the fitted axis, the grasp frame's axes, the visible end and
  the confidence (select it in the Image panel's annotation list).
* ``/vision/detection``: ``maris.VisionDetection``, each new detection with what
  the detector saw (camera-frame pose, visible pipe end, quality factors).

Schemas follow Foxglove's field names; every object has ``properties`` and no
field uses a type union (Foxglove Studio rejects such channels). Times are the
backend clock; the writer adds ``t`` to every message as on all channels.
"""

from __future__ import annotations

import base64
from typing import Any

_TIME = {"type": "object", "title": "time", "properties": {"sec": {"type": "integer", "minimum": 0},
                                                           "nsec": {"type": "integer", "minimum": 0, "maximum": 999999999}}}
_POINT2 = {"type": "object", "title": "foxglove.Point2", "properties": {"x": {"type": "number"}, "y": {"type": "number"}}}
_COLOR = {"type": "object", "title": "foxglove.Color",
          "properties": {"r": {"type": "number"}, "g": {"type": "number"}, "b": {"type": "number"}, "a": {"type": "number"}}}
_NUM = {"type": "number"}
_T = {"t": {"type": "number", "description": "backend clock, s"}}

COMPRESSED_IMAGE = {
    "title": "foxglove.CompressedImage",
    "description": "A compressed image (downscaled JPEG of the left camera)",
    "type": "object",
    "properties": {
        **_T,
        "timestamp": {**_TIME, "description": "image time (backend clock)"},
        "frame_id": {"type": "string", "description": "optical frame of the camera"},
        "data": {"type": "string", "contentEncoding": "base64", "description": "JPEG bytes"},
        "format": {"type": "string", "description": "jpeg"},
    },
}

IMAGE_ANNOTATIONS = {
    "title": "foxglove.ImageAnnotations",
    "description": "The pipe detection drawn on the camera image (pixels, origin at the top-left corner)",
    "type": "object",
    "properties": {
        **_T,
        "circles": {"type": "array", "items": {"type": "object", "title": "foxglove.CircleAnnotation", "properties": {
            "timestamp": _TIME, "position": _POINT2, "diameter": _NUM, "thickness": _NUM, "fill_color": _COLOR, "outline_color": _COLOR}}},
        "points": {"type": "array", "items": {"type": "object", "title": "foxglove.PointsAnnotation", "properties": {
            "timestamp": _TIME, "type": {"type": "integer", "description": "0 unknown, 1 points, 2 line loop, 3 line strip, 4 line list"},
            "points": {"type": "array", "items": _POINT2}, "outline_color": _COLOR,
            "outline_colors": {"type": "array", "items": _COLOR}, "fill_color": _COLOR, "thickness": _NUM}}},
        "texts": {"type": "array", "items": {"type": "object", "title": "foxglove.TextAnnotation", "properties": {
            "timestamp": _TIME, "position": _POINT2, "text": {"type": "string"}, "font_size": _NUM,
            "text_color": _COLOR, "background_color": _COLOR}}},
    },
}

_VEC = {"type": "array", "items": {"type": "number"}}
VISION_DETECTION = {
    "title": "VisionDetection",
    "description": "A detection of the stereo pipe detector: grasp frame in the vehicle frame (vTg) and the "
                   "left camera frame (cTg), 4x4 row major; visible pipe end in the camera frame (m); quality.",
    "type": "object",
    "properties": {
        **_T,
        "image_t": {"type": "number", "description": "image time, s"},
        "confidence": _NUM,
        "reason": {"type": "string", "description": "why the confidence is below 1 (empty when nothing is off)"},
        "vehicle_T_grasp": _VEC,
        "cam_T_grasp": _VEC,
        "end_cam": _VEC,
        "radius_m": _NUM,
        "elapsed_ms": {"type": "number", "description": "detector's cost for this pair, ms"},
        "quality": {"type": "object", "properties": {"range_m": _NUM, "plane_rms_px": _NUM, "depth_sigma_m": _NUM, "length_m": _NUM}},
    },
    "required": ["t", "image_t", "confidence"],
}

#: topic -> (schema name, JSON schema); merged into :data:`mission.logs.channels.CHANNELS`.
VISION_CHANNELS: dict[str, tuple[str, dict]] = {
    "/camera/left/compressed": ("foxglove.CompressedImage", COMPRESSED_IMAGE),
    "/vision/annotations": ("foxglove.ImageAnnotations", IMAGE_ANNOTATIONS),
    "/vision/detection": ("maris.VisionDetection", VISION_DETECTION),
}

#: Topics whose messages are images (left out of CSV exports and plots).
IMAGE_TOPICS = ("/camera/left/compressed", "/vision/annotations")


def stamp(t: float) -> dict:
    """Foxglove time of a backend clock reading (s, clamped at 0)."""
    ns = max(0, int(round(t * 1e9)))
    return {"sec": ns // 1_000_000_000, "nsec": ns % 1_000_000_000}


def image_message(frame: Any) -> dict:
    """``foxglove.CompressedImage`` of a :class:`hal.interfaces.CameraFrame`."""
    return {"timestamp": stamp(frame.t), "frame_id": frame.frame_id, "data": base64.b64encode(frame.jpeg).decode("ascii"), "format": "jpeg"}


def _color(c: Any) -> dict:
    r, g, b, a = (float(x) for x in c)
    return {"r": r, "g": g, "b": b, "a": a}


def annotations_message(frame: Any) -> dict:
    """``foxglove.ImageAnnotations`` of a frame's overlay (pixel centres -> corner origin: +0.5)."""
    ts = stamp(frame.t)
    ov = frame.overlay or {}
    pt = lambda p: {"x": float(p[0]) + 0.5, "y": float(p[1]) + 0.5}  # noqa: E731
    clear = {"r": 0.0, "g": 0.0, "b": 0.0, "a": 0.0}
    points = [{"timestamp": ts, "type": 3, "points": [pt(p) for p in ln["points"]], "outline_color": _color(ln["color"]),
               "outline_colors": [], "fill_color": clear, "thickness": float(ln.get("thickness", 1.0))} for ln in ov.get("lines", [])]
    circles = [{"timestamp": ts, "position": pt(c["position"]), "diameter": float(c["diameter"]), "thickness": 2.0,
                "fill_color": clear, "outline_color": _color(c["color"])} for c in ov.get("circles", [])]
    texts = [{"timestamp": ts, "position": pt(x["position"]), "text": str(x["text"]), "font_size": 12.0, "text_color": _color(x["color"]),
              "background_color": {"r": 0.0, "g": 0.0, "b": 0.0, "a": 0.5}} for x in ov.get("texts", [])]
    return {"circles": circles, "points": points, "texts": texts}


def detection_message(det: Any) -> dict | None:
    """``maris.VisionDetection`` of a :class:`hal.interfaces.Detection` with ``details`` (None without)."""
    d = getattr(det, "details", None)
    if not d:
        return None
    flat = lambda m: [float(x) for row in m for x in row] if m is not None else []  # noqa: E731
    q = d.get("quality") or {}
    return {
        "image_t": float(det.t), "confidence": float(det.confidence), "reason": str(d.get("reason") or ""),
        "vehicle_T_grasp": [float(x) for x in det.pose.reshape(-1)], "cam_T_grasp": flat(d.get("cam_T_grasp")),
        "end_cam": [float(x) for x in (d.get("end_cam") or [])], "radius_m": float(d.get("radius_m") or 0.0),
        "elapsed_ms": float(d.get("elapsed_ms") or 0.0),
        "quality": {k: float(q[k]) for k in ("range_m", "plane_rms_px", "depth_sigma_m", "length_m") if q.get(k) is not None},
    }


def write_detection(log: Any, t: float, det: Any) -> None:
    """Log a new detection's details on ``/vision/detection`` (nothing for simple models)."""
    msg = detection_message(det)
    if msg is not None:
        log.write("/vision/detection", t, msg)


def write_frames(log: Any, t: float, detector: Any) -> None:
    """Log the detector's new camera frames and their annotations."""
    frames = getattr(detector, "camera_frames", None)
    for frame in frames() if frames is not None else ():
        topic = f"/camera/{frame.camera}/compressed"
        if topic not in VISION_CHANNELS:
            continue
        log.write(topic, t, image_message(frame))
        if frame.overlay is not None:
            log.write("/vision/annotations", t, annotations_message(frame))
