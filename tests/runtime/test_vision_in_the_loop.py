"""Acceptance: the reference mission on the simulator with rendered images and
the real detector, and its log read back with the independent `mcap` reader:
camera frames and annotations decoded with the protobuf schemas written in the
file (foxglove.CompressedImage / ImageAnnotations), detections as JSON."""

from __future__ import annotations

import json
from pathlib import Path

import cv2
import numpy as np
import pytest
from google.protobuf import descriptor_pb2, descriptor_pool, message_factory
from mcap.reader import make_reader

from mission.logs.channels import schema_problems
from mission.logs.vision_channels import VISION_CHANNELS, VISION_WELL_KNOWN
from mission.runtime.api import run_mission
from mission.runtime.options import RunOptions, RunTarget

ROOT = Path(__file__).resolve().parents[2]


def _decoder(schema):  # noqa: ANN001, ANN202 - from the schema stored in the file, not the SDK
    fds = descriptor_pb2.FileDescriptorSet.FromString(schema.data)
    pool = descriptor_pool.DescriptorPool()
    for fd in fds.file:
        pool.Add(fd)
    return message_factory.GetMessageClass(pool.FindMessageTypeByName(schema.name))


def test_vision_json_channel_is_one_foxglove_parses() -> None:
    for topic, (_, schema) in VISION_CHANNELS.items():
        assert schema_problems(schema) == [], topic


@pytest.mark.slow
def test_reference_mission_with_rendered_vision(tmp_path: Path) -> None:
    log = tmp_path / "vision.mcap"
    # half the rendered resolution and half the image rate keep the test short (the scenario: 646 x 482 at 10 Hz)
    res = run_mission(
        RunTarget(
            str(ROOT / "missions" / "maris_pipe_recovery.yaml"),
            scenario="pool_vision",
            seed=1,
            overrides={
                "vision.image_width": 323,
                "vision.image_height": 241,
                "vision.rate_hz": 5.0,
                "vision.log_frames_hz": 0.5,
            },
        ),
        RunOptions(log_path=str(log)),
    )
    assert res.outcome == "succeeded", res.failure_cause
    assert res.grasp == "holding"
    topics: dict[str, list] = {}
    decoders: dict[int, object] = {}
    with open(log, "rb") as f:
        for schema, channel, message in make_reader(f).iter_messages():
            if channel.topic in VISION_WELL_KNOWN:
                assert (schema.name, channel.message_encoding) == (
                    VISION_WELL_KNOWN[channel.topic].get_schema().name,
                    "protobuf",
                )
                dec = decoders.setdefault(schema.id, _decoder(schema))
                topics.setdefault(channel.topic, []).append((message.log_time, dec.FromString(message.data)))
            elif channel.topic in VISION_CHANNELS or channel.topic == "/detector":
                topics.setdefault(channel.topic, []).append((message.log_time, json.loads(message.data)))
    images = topics["/camera/left/compressed"]
    assert len(images) >= 10
    _, img_msg = images[-1]
    img = cv2.imdecode(np.frombuffer(img_msg.data, np.uint8), cv2.IMREAD_COLOR)
    assert (
        img_msg.format == "jpeg" and img_msg.frame_id == "stereo_camera" and img.shape == (239, 320, 3)
    )  # 320 px wide
    ann = [m for _, m in topics["/vision/annotations"] if m.points]
    assert ann and ann[-1].points[0].type == 3 and len(ann[-1].points[0].points) >= 2
    stamps = {(m.timestamp.seconds, m.timestamp.nanos) for _, m in images}
    assert all((m.timestamp.seconds, m.timestamp.nanos) in stamps for m in ann)  # each drawing goes with its image
    dets = [m for _, m in topics["/vision/detection"]]
    assert dets and all(0.0 < d["confidence"] <= 1.0 for d in dets) and len(dets[-1]["cam_T_grasp"]) == 16
    assert len(topics["/detector"]) == len(dets)
