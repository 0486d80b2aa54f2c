"""The log as Foxglove reads it: read back with the `mcap` package, every
well-known channel decoded with the protobuf schema of the SDK's class, the
frame tree checked link by link against the KCL model, the URDF attachment and
the metadata records; every maris.* JSON schema within what Foxglove parses."""

from __future__ import annotations

import math

import numpy as np
import pytest
from google.protobuf import descriptor_pb2, descriptor_pool, message_factory
from mcap.reader import make_reader

from kcl.model import DEFAULT_URDF, UvmsModel
from kcl.rotations import homogeneous
from mission.logs.channels import CHANNELS, schema_problems
from mission.logs.vision_channels import VISION_WELL_KNOWN
from mission.logs.wellknown import WELL_KNOWN


def _decoder(schema):
    fds = descriptor_pb2.FileDescriptorSet.FromString(schema.data)
    pool = descriptor_pool.DescriptorPool()
    for fd in fds.file:
        pool.Add(fd)
    return message_factory.GetMessageClass(pool.FindMessageTypeByName(schema.name))


@pytest.fixture(scope="module")
def decoded(reference_log):
    """topic -> [(log_time ns, decoded protobuf message)], plus the reader's summary, attachments, metadata."""
    _, path = reference_log
    out: dict[str, list] = {}
    with open(path, "rb") as f:
        reader = make_reader(f)
        summary = reader.get_summary()
        decoders = {}
        for schema, channel, message in reader.iter_messages():
            if channel.topic not in WELL_KNOWN:
                continue
            sdk = WELL_KNOWN[channel.topic].get_schema()
            assert (schema.name, schema.encoding, channel.message_encoding) == (sdk.name, "protobuf", "protobuf")
            assert schema.data == bytes(sdk.data)
            if schema.id not in decoders:
                decoders[schema.id] = _decoder(schema)
            out.setdefault(channel.topic, []).append((message.log_time, decoders[schema.id].FromString(message.data)))
        attachments = list(reader.iter_attachments())
        metadata = {m.name: dict(m.metadata) for m in reader.iter_metadata()}
    return out, summary, attachments, metadata


def test_every_json_schema_is_one_foxglove_parses():
    for topic, (_, schema) in CHANNELS.items():
        assert schema_problems(schema) == [], topic
    assert schema_problems({"type": "object", "properties": {"x": {"type": ["number", "null"]}}})
    assert schema_problems({"type": "object", "properties": {"m": {"type": "object"}}})


@pytest.mark.slow
def test_every_well_known_channel_is_written_and_decodes(decoded, reference_log):
    msgs, summary, _, _ = decoded
    assert set(msgs) == set(WELL_KNOWN) - set(VISION_WELL_KNOWN)  # no camera images without rendered vision
    result, _ = reference_log
    model = UvmsModel.load()
    joints = msgs["/arm/joints"][-1][1]
    assert [j.name for j in joints.joints] == list(model.joint_names)
    assert all(math.isfinite(j.position) and math.isfinite(j.velocity) for j in joints.joints)
    robot = msgs["/scene/robot"][0][1]
    frames = {e.frame_id for e in robot.entities}
    assert "base_link" in frames and "gripper_link" in frames and all(e.frame_locked for e in robot.entities)
    hull = next(e for e in robot.entities if e.frame_id == "base_link").cubes[0]
    assert (hull.size.x, hull.size.y, hull.size.z) == pytest.approx((1.3, 0.9, 1.0))
    world = {e.id: e for e in msgs["/scene/world"][0][1].entities}
    assert set(world) == {"pool", "geofence", "pipe", "waypoints"}
    assert len(world["waypoints"].spheres) == 7 and world["pipe"].frame_id == "pipe"
    assert len(msgs["/waypoints"][0][1].poses) == 7  # 6 survey waypoints and the lift goal
    assert msgs["/goal/tool"] and msgs["/goal/tool"][-1][1].frame_id == "world"
    # every event is on /log, with its level
    events = [e for e in result.events]
    logs = [m for _, m in msgs["/log"]]
    assert [m.message for m in logs] == [e.message for e in events]
    fault_level = type(logs[0]).Level.Value("ERROR")
    assert all((m.level == fault_level) == (e.level == "fault") for m, e in zip(logs, events))
    # stamps: message timestamp == log time
    for topic in ("/tf", "/log", "/arm/joints"):
        for ns, m in msgs[topic][:50]:
            ts = m.transforms[0].timestamp if topic == "/tf" else m.timestamp
            assert ts.seconds * 1_000_000_000 + ts.nanos == ns


def _compose(by_child: dict, frame: str, root: str) -> np.ndarray:
    """Pose of ``frame`` in ``root`` along the parent chain of one /tf message."""
    T = np.eye(4)
    seen = set()
    while frame != root:
        assert frame in by_child, f"{frame} has no parent chain to {root}"
        assert frame not in seen
        seen.add(frame)
        tr = by_child[frame]
        q = tr.rotation
        from pinocchio import Quaternion

        R = Quaternion(q.w, q.x, q.y, q.z).toRotationMatrix()
        T = homogeneous(R, [tr.translation.x, tr.translation.y, tr.translation.z]) @ T
        frame = tr.parent_frame_id
    return T


@pytest.mark.slow
def test_frame_tree_reaches_world_and_matches_the_model(decoded):
    msgs, _, _, _ = decoded
    model = UvmsModel.load()
    links = [f.name for f in model.pin_model.frames if f.type.name == "BODY"]
    tf = msgs["/tf"]
    joints = dict(msgs["/arm/joints"])
    checked = 0
    for ns, m in tf[:: max(1, len(tf) // 12)]:
        by_child = {tr.child_frame_id: tr for tr in m.transforms}
        assert len(by_child) == len(m.transforms), "a frame with two parents"
        for link in links + ["vehicle_level"]:
            _compose(by_child, link, "map")  # every link has a chain to the root
        wT = {link: _compose(by_child, link, "world") for link in ("base_link", "tool", "stereo_camera")}
        q = np.array([j.position for j in joints[ns].joints])
        base = wT["base_link"]
        from kcl.rotations import matrix_to_rpy

        eta = np.concatenate([base[:3, 3], matrix_to_rpy(base[:3, :3])])
        for link in ("tool", "stereo_camera"):
            np.testing.assert_allclose(wT[link], model.frame_pose_world(q, eta, link), atol=1e-6)
        # map is z-up: a point below the vehicle in NED is lower in map
        mT = _compose(by_child, "base_link", "map")
        assert mT[2, 3] == pytest.approx(-base[2, 3])
        checked += 1
    assert checked >= 10
    last = {tr.child_frame_id for tr in tf[-1][1].transforms}
    assert {"tool_goal", "grasp_pose", "detection", "pipe"} <= last


@pytest.mark.slow
def test_urdf_attachment_and_metadata(decoded, reference_log):
    _, summary, attachments, metadata = decoded
    result, _ = reference_log
    assert [(a.name, a.media_type) for a in attachments] == [("r2_uma.urdf", "application/xml")]
    assert attachments[0].data == DEFAULT_URDF.read_bytes()
    run = metadata["maris.run"]
    assert (run["mission"], run["scenario"], run["seed"], run["time_base"]) == (
        "maris_pipe_recovery",
        "pool_fixed",
        "1",
        "simulated",
    )
    assert run["version.maris-uvms"] and run["version.foxglove-sdk"] and run["wall_start_utc"]
    assert metadata["maris.result"]["outcome"] == result.outcome == "succeeded"
    assert summary.statistics.message_start_time < 60 * 1_000_000_000  # simulated time from 0


def test_field_runs_get_wall_clock_times():
    import time

    from mission.logs.runmeta import time_base

    offset, meta = time_base(False, 1234.5)
    assert meta["time_base"] == "wall_clock"
    assert abs(offset + 1234.5e9 - time.time_ns()) < 5e9
    assert time_base(True, 0.0)[0] == 0
