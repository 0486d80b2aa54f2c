"""A simple baseline beside the pipe detector: HSV threshold + one straight line per image.

Per image: the MARIS HSV thresholds, a morphological opening, the largest
connected region; its centre line (``cv2.fitLine`` over the region's pixels,
undistorted) spans, with the camera centre, a plane containing (nearly) the
pipe axis. The axis is the intersection of the left and right planes; the
visible end is the region's extreme point along its line (the one not on the
image border) brought onto the axis. No edges, no cylinder model, no
refinement: what a first attempt looks like.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from vision.calibration import CameraModel, StereoCalibration, undistort_points
from vision.silhouette import HsvRange


@dataclass
class BaselineResult:
    """Axis point and unit direction (left camera frame, m), the visible end (or None)."""

    point: np.ndarray
    direction: np.ndarray
    end: np.ndarray | None


def _region(img: np.ndarray, hsv: HsvRange, min_area: int) -> np.ndarray | None:
    import cv2

    h = cv2.cvtColor(img, cv2.COLOR_BGR2HSV)
    m = cv2.inRange(h, (hsv.hue[0], hsv.sat_min, hsv.val_min), (hsv.hue[1], 255, 255))
    m = cv2.morphologyEx(m, cv2.MORPH_OPEN, cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (5, 5)))
    n, labels, stats, _ = cv2.connectedComponentsWithStats(m)
    if n <= 1:
        return None
    k = 1 + int(np.argmax(stats[1:, cv2.CC_STAT_AREA]))
    if stats[k, cv2.CC_STAT_AREA] < min_area:
        return None
    ys, xs = np.nonzero(labels == k)
    return np.column_stack([xs, ys]).astype(np.float64)


def _plane(px: np.ndarray, cam: CameraModel, R: np.ndarray, t: np.ndarray) -> tuple[np.ndarray, float, np.ndarray]:
    """Plane (left frame) through camera (R, t) and the region's centre line; the
    line's unit direction in undistorted normalized coordinates and its centroid."""
    import cv2

    sub = px[:: max(1, len(px) // 4000)]
    und = undistort_points(sub, cam)
    vx, vy, x0, y0 = cv2.fitLine(und.astype(np.float32), cv2.DIST_L2, 0, 0.01, 0.01).reshape(-1)
    p1 = np.array([x0, y0, 1.0])
    p2 = np.array([x0 + vx, y0 + vy, 1.0])
    n_cam = np.cross(p1, p2)
    n_cam /= np.linalg.norm(n_cam)
    n = R.T @ n_cam
    return n, float(-n_cam @ t), np.array([vx, vy, x0, y0])


MARIS_HSV = HsvRange()


def detect(
    left: np.ndarray, right: np.ndarray, calib: StereoCalibration, hsv: HsvRange = MARIS_HSV
) -> BaselineResult | None:
    """The baseline's axis and end, or None (no region in one of the images)."""
    h, w = left.shape[:2]
    min_area = max(12, int(2e-4 * w * h))
    regions = [_region(left, hsv, min_area), _region(right, hsv, min_area)]
    if any(r is None for r in regions):
        return None
    cams = [(calib.left, np.eye(3), np.zeros(3)), (calib.right, calib.R, calib.T)]
    planes = [_plane(px, cam, R, t) for px, (cam, R, t) in zip(regions, cams)]  # type: ignore[arg-type]
    (n1, d1, line), (n2, d2, _) = planes
    a = np.cross(n1, n2)
    if np.linalg.norm(a) < 1e-6:
        return None
    a /= np.linalg.norm(a)
    A = np.array([n1, n2, a])
    p = np.linalg.solve(A, np.array([d1, d2, 0.0]))
    # visible end: the left region's extreme point along its line, away from the border
    px = regions[0]
    assert px is not None
    s = (px - px.mean(axis=0)) @ np.array([line[0], line[1]]) / np.hypot(line[0], line[1])
    end = None
    for idx in (int(np.argmin(s)), int(np.argmax(s))):
        u, v = px[idx]
        if 3 < u < w - 4 and 3 < v < h - 4:
            ray = np.append(undistort_points(px[idx : idx + 1], calib.left)[0], 1.0)
            ray /= np.linalg.norm(ray)
            b = float(a @ ray)
            den = 1.0 - b * b
            if den > 1e-9:
                sa = (b * (ray @ p) - a @ p) / den
                end = p + sa * a
                break
    return BaselineResult(p, a, end)
