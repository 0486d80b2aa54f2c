"""Reading image pairs and writing results for ``maris vision`` (no CLI parsing here).

A source is an image file, a folder of images (name order) or a video file;
:func:`iter_pairs` walks two of them in step (or one side-by-side source) and
yields every pair, with a readable error instead of an image when a frame
cannot be read, so that one corrupt frame does not end the run.
"""

from __future__ import annotations

import csv
import json
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

import numpy as np

# Imports inside the functions below are deliberate: shell completion (argcomplete) builds
# the parser on every Tab, so a command loads its heavy modules only when it runs.

IMAGE_SUFFIXES = (".png", ".jpg", ".jpeg", ".bmp", ".tif", ".tiff", ".ppm", ".pgm")


class SourceError(Exception):
    """A source that cannot be read at all (missing file, not an image or video)."""


@dataclass
class Pair:
    index: int
    name: str
    left: np.ndarray | None
    right: np.ndarray | None
    error: str = ""


def _frames(source: str) -> Iterator[tuple[str, np.ndarray | None, str]]:
    """``(name, image or None, error)`` for every frame of an image, folder or video."""
    import cv2

    p = Path(source)
    if not p.exists():
        raise SourceError(f"{source}: no such file or folder")
    if p.is_dir():
        files = sorted(f for f in p.iterdir() if f.suffix.lower() in IMAGE_SUFFIXES)
        if not files:
            raise SourceError(f"{source}: no images in this folder ({', '.join(IMAGE_SUFFIXES)})")
        for f in files:
            img = cv2.imread(str(f), cv2.IMREAD_COLOR)
            yield f.name, img, "" if img is not None else f"{f}: cannot decode the image (corrupt or not an image)"
        return
    if p.suffix.lower() in IMAGE_SUFFIXES:
        img = cv2.imread(str(p), cv2.IMREAD_COLOR)
        if img is None:
            raise SourceError(f"{source}: cannot decode the image (corrupt or not an image)")
        yield p.name, img, ""
        return
    cap = cv2.VideoCapture(str(p))
    if not cap.isOpened():
        raise SourceError(f"{source}: not an image, a folder of images or a readable video")
    try:
        i = 0
        while True:
            ok, img = cap.read()
            if not ok:
                break
            yield f"{p.stem}#{i:05d}", img, ""
            i += 1
        if i == 0:
            raise SourceError(f"{source}: the video has no readable frame")
    finally:
        cap.release()


def iter_pairs(left: str, right: str | None = None, *, every: int = 1, limit: int | None = None) -> Iterator[Pair]:
    """Pairs from two sources in step, or from one side-by-side source (``right`` None)."""
    n = 0
    if right is None:
        it = _frames(left)
        for i, (name, img, err) in enumerate(it):
            if i % every:
                continue
            if img is None:
                yield Pair(i, name, None, None, err)
            else:
                w = img.shape[1] // 2
                yield Pair(i, name, img[:, :w], img[:, w : 2 * w])
            n += 1
            if limit is not None and n >= limit:
                return
        return
    a, b = _frames(left), _frames(right)
    for i, ((na, ia, ea), (nb, ib, eb)) in enumerate(zip(a, b)):
        if i % every:
            continue
        yield Pair(i, na if na == nb else f"{na}|{nb}", ia, ib, "; ".join(e for e in (ea, eb) if e))
        n += 1
        if limit is not None and n >= limit:
            return


CSV_FIELDS = (
    "index",
    "name",
    "confidence",
    "x_m",
    "y_m",
    "z_m",
    "axis_x",
    "axis_y",
    "axis_z",
    "end_x_m",
    "end_y_m",
    "end_z_m",
    "radius_m",
    "range_m",
    "elapsed_ms",
    "frame",
    "reason",
)


def pose_row(pair: Pair, det, frame: str) -> dict:
    """One CSV row: the grasp frame origin and axis (camera or vehicle frame), the visible end."""
    T = det.vehicle_T_grasp if frame == "vehicle" and det.vehicle_T_grasp is not None else det.cam_T_grasp
    row: dict = {
        "index": pair.index,
        "name": pair.name,
        "confidence": round(det.confidence, 4),
        "reason": det.reason,
        "elapsed_ms": round(det.elapsed_ms, 2),
        "frame": frame if T is not None else "",
    }
    if T is not None:
        row.update(x_m=T[0, 3], y_m=T[1, 3], z_m=T[2, 3], axis_x=T[0, 0], axis_y=T[1, 0], axis_z=T[2, 0])
    if det.end_cam is not None:
        row.update(end_x_m=det.end_cam[0], end_y_m=det.end_cam[1], end_z_m=det.end_cam[2])
    if det.radius_m is not None:
        row["radius_m"] = det.radius_m
    if det.quality.get("range_m") is not None:
        row["range_m"] = det.quality["range_m"]
    return {k: (round(v, 6) if isinstance(v, float) else v) for k, v in row.items()}


def write_results(out: Path, rows: list[dict], records: list[dict]) -> tuple[Path, Path]:
    """``poses.csv`` (one row per pair) and ``poses.json`` (full detections) in ``out``."""
    out.mkdir(parents=True, exist_ok=True)
    csv_path, json_path = out / "poses.csv", out / "poses.json"
    with open(csv_path, "w", newline="", encoding="utf-8") as f:
        w = csv.DictWriter(f, fieldnames=CSV_FIELDS, restval="")
        w.writeheader()
        w.writerows(rows)
    json_path.write_text(json.dumps(records, indent=1, default=_json_default), encoding="utf-8")
    return csv_path, json_path


def _json_default(o: object) -> object:
    if isinstance(o, np.ndarray):
        return o.tolist()
    if isinstance(o, (np.floating, np.integer)):
        return o.item()
    return str(o)
