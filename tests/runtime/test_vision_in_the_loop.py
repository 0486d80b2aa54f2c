"""Acceptance: the reference mission on the simulator with rendered images and
the real detector, and its log read back with the independent `mcap` reader
(camera frames in Foxglove's CompressedImage shape, annotations, detections)."""

from __future__ import annotations

import base64
import json
from pathlib import Path

import cv2
import numpy as np
from mcap.reader import make_reader

from mission.logs.vision_channels import VISION_CHANNELS
from mission.runtime import run_mission

ROOT = Path(__file__).resolve().parents[2]


def _walk(schema: dict, where: str = "") -> list[str]:
    """Schema shapes Foxglove Studio rejects: type unions, objects without properties."""
    bad = []
    if isinstance(schema.get("type"), list):
        bad.append(f"{where}: type union {schema['type']}")
    if schema.get("type") == "object" and "properties" not in schema:
        bad.append(f"{where}: object without properties")
    for k, v in (schema.get("properties") or {}).items():
        bad += _walk(v, f"{where}.{k}")
    if isinstance(schema.get("items"), dict):
        bad += _walk(schema["items"], f"{where}[]")
    return bad


def test_vision_channel_schemas_are_foxglove_friendly() -> None:
    for topic, (name, schema) in VISION_CHANNELS.items():
        assert _walk(schema, topic) == [], name


def test_reference_mission_with_rendered_vision(tmp_path: Path) -> None:
    log = tmp_path / "vision.mcap"
    # half the rendered resolution keeps the test short; the scenario's default is 646 x 482
    res = run_mission(str(ROOT / "missions" / "maris_pipe_recovery.yaml"), scenario="pool_vision", seed=1,
                      overrides={"vision.image_width": 323, "vision.image_height": 241, "vision.log_frames_hz": 0.5}, log_path=str(log))
    assert res.outcome == "succeeded", res.failure_cause
    assert res.grasp == "holding"
    topics: dict[str, list] = {}
    with open(log, "rb") as f:
        for schema, channel, message in make_reader(f).iter_messages():
            topics.setdefault(channel.topic, []).append((schema.name, json.loads(message.data)))
    images = topics["/camera/left/compressed"]
    assert len(images) >= 10 and images[0][0] == "foxglove.CompressedImage"
    name, msg = images[-1]
    img = cv2.imdecode(np.frombuffer(base64.b64decode(msg["data"]), np.uint8), cv2.IMREAD_COLOR)
    assert msg["format"] == "jpeg" and img.shape == (239, 320, 3)  # downscaled to 320 px wide
    assert set(msg["timestamp"]) == {"sec", "nsec"} and msg["frame_id"] == "stereo_camera"
    ann = [m for _, m in topics["/vision/annotations"] if m["points"]]
    assert ann and ann[0]["points"][0]["type"] == 3 and {"x", "y"} <= set(ann[0]["points"][0]["points"][0])
    dets = [m for _, m in topics["/vision/detection"]]
    assert dets and all(0.0 < d["confidence"] <= 1.0 for d in dets) and len(dets[-1]["cam_T_grasp"]) == 16
    assert len(topics["/detector"]) == len(dets)
