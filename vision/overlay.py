"""Drawings of a detection for operators: on PNGs and as Foxglove image annotations.

:func:`overlay_primitives` turns a :class:`~vision.detector.PipeDetection` into
image-space primitives of the left image (optionally scaled to a smaller
preview): the straight edges found, the fitted axis and pipe outline, the
visible end, and the grasp frame's axes (x red, y green, z blue, 10 cm).
:func:`draw_overlay` draws them (plus the colour region's outline) on a copy
of the image; the run log carries the same primitives as a Foxglove
``ImageAnnotations`` message next to the camera frame.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import cv2
import numpy as np

from vision.calibration import CameraModel, StereoCalibration, project_points

if TYPE_CHECKING:
    from vision.detector import PipeDetection

#: RGBA colours (0-1).
EDGE = (0.0, 1.0, 1.0, 1.0)
AXIS = (1.0, 0.0, 1.0, 1.0)
END = (1.0, 1.0, 1.0, 1.0)
FRAME = ((1.0, 0.0, 0.0, 1.0), (0.0, 1.0, 0.0, 1.0), (0.0, 0.4, 1.0, 1.0))


def _project(cam: CameraModel, pts: np.ndarray) -> np.ndarray | None:
    pts = np.asarray(pts, dtype=float).reshape(-1, 3)
    if np.any(pts[:, 2] <= 0.05):
        return None
    return project_points(pts, cam)


def overlay_primitives(det: PipeDetection, calib: StereoCalibration | CameraModel, scale: float = 1.0) -> dict:
    """``{"lines": [{"points": [[u, v], ...], "color": rgba, "thickness": px}], "circles": [...],
    "texts": [...]}`` in pixels of the left image (or the one camera's, given its
    :class:`CameraModel`) resized by ``scale`` (pixel-centre coordinates: the centre
    of the top-left pixel is (0, 0))."""
    sc = lambda uv: (np.asarray(uv) + 0.5) * scale - 0.5  # noqa: E731 - resize keeps pixel areas
    cam = calib.left if isinstance(calib, StereoCalibration) else calib
    lines: list[dict] = []
    circles: list[dict] = []
    texts: list[dict] = []
    view = det.views.get("left", {}) if isinstance(det.views, dict) else {}
    for limb in view.get("limbs", []):
        seg = np.asarray(limb["segment"], dtype=float)  # undistorted pixels
        # back to raw pixels through the camera model (normalized coords first)
        xy = (seg - cam.K[:2, 2]) / np.diag(cam.K)[:2]
        raw = _project(cam, np.column_stack([xy, np.ones(len(xy))]))
        if raw is not None:
            lines.append({"points": sc(raw).tolist(), "color": EDGE, "thickness": 2.0})
    if det.axis_point_cam is not None and det.axis_dir_cam is not None and det.cam_T_grasp is not None:
        g = det.cam_T_grasp
        pts = [g[:3, 3] + s * det.axis_dir_cam for s in np.linspace(-0.5, 0.5, 11)]
        uv = _project(cam, np.array(pts))
        if uv is not None:
            lines.append({"points": sc(uv).tolist(), "color": AXIS, "thickness": 1.0})
        for i, col in enumerate(FRAME):
            uv = _project(cam, np.array([g[:3, 3], g[:3, 3] + 0.1 * g[:3, i]]))
            if uv is not None:
                lines.append({"points": sc(uv).tolist(), "color": col, "thickness": 3.0})
        uv = _project(cam, g[:3, 3][None])
        if uv is not None:
            texts.append(
                {"position": (sc(uv[0]) + [8.0, -8.0]).tolist(), "text": f"{det.confidence:.2f}", "color": END}
            )
    if det.end_cam is not None:
        uv = _project(cam, np.asarray(det.end_cam)[None])
        if uv is not None:
            circles.append({"position": sc(uv[0]).tolist(), "diameter": 10.0, "color": END})
    if det.confidence <= 0.0:
        texts.append({"position": [10.0, 20.0], "text": (det.reason or "no detection")[:80], "color": END})
    return {"lines": lines, "circles": circles, "texts": texts}


def draw_overlay(
    image: np.ndarray, det: PipeDetection, calib: StereoCalibration, region_mask: np.ndarray | None = None
) -> np.ndarray:
    """A copy of the left ``image`` with the detection drawn on it (and the outline
    of ``region_mask``, the colour region, in yellow)."""
    out = image.copy()
    h, w = out.shape[:2]
    sx = w / calib.left.width
    if region_mask is not None:
        contours, _ = cv2.findContours(region_mask, cv2.RETR_EXTERNAL, cv2.CHAIN_APPROX_SIMPLE)
        cv2.drawContours(out, contours, -1, (0, 255, 255), 1)
    prim = overlay_primitives(det, calib, sx)
    bgr = lambda c: (int(255 * c[2]), int(255 * c[1]), int(255 * c[0]))  # noqa: E731
    for ln in prim["lines"]:
        pts = np.round(np.asarray(ln["points"])).astype(np.int32)
        cv2.polylines(out, [pts], False, bgr(ln["color"]), max(1, int(ln["thickness"])), cv2.LINE_AA)
    for c in prim["circles"]:
        p = tuple(int(round(v)) for v in c["position"])
        cv2.circle(out, p, int(c["diameter"] / 2), bgr(c["color"]), 2, cv2.LINE_AA)
    for t in prim["texts"]:
        p = tuple(int(round(v)) for v in t["position"])
        cv2.putText(out, t["text"], p, cv2.FONT_HERSHEY_SIMPLEX, 0.5, (0, 0, 0), 3, cv2.LINE_AA)
        cv2.putText(out, t["text"], p, cv2.FONT_HERSHEY_SIMPLEX, 0.5, bgr(t["color"]), 1, cv2.LINE_AA)
    return out


def jpeg_preview(image: np.ndarray, max_width: int = 320, quality: int = 70) -> tuple[bytes, int, int, float]:
    """Downscaled JPEG of a BGR image: ``(bytes, width, height, scale)``."""
    h, w = image.shape[:2]
    scale = min(1.0, max_width / float(w))
    small = (
        cv2.resize(image, (max(1, int(round(w * scale))), max(1, int(round(h * scale)))), interpolation=cv2.INTER_AREA)
        if scale < 1
        else image
    )
    ok, buf = cv2.imencode(".jpg", small, [cv2.IMWRITE_JPEG_QUALITY, int(quality)])
    if not ok:
        raise ValueError("JPEG encoding failed")
    return buf.tobytes(), small.shape[1], small.shape[0], scale
