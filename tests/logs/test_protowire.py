"""mission.logs.protowire against the SDK: its bytes decoded by the ``protobuf``
runtime with the SDK's own schemas (as Foxglove reads the log) hold what the
SDK's message objects hold, for any frames, names, numbers and times."""

from __future__ import annotations

import math

import pytest
from foxglove import messages as fm
from google.protobuf import descriptor_pb2, descriptor_pool, message_factory
from hypothesis import given, settings
from hypothesis import strategies as st

from mission.logs.frames import Transform
from mission.logs.protowire import FrameTransformsEncoder, JointStatesEncoder, pose_in_frame, varint


def _decoder(cls):
    schema = cls.get_schema()
    pool = descriptor_pool.DescriptorPool()
    for fd in descriptor_pb2.FileDescriptorSet.FromString(bytes(schema.data)).file:
        pool.Add(fd)
    return message_factory.GetMessageClass(pool.FindMessageTypeByName(schema.name))


TF = _decoder(fm.FrameTransforms)
JOINTS = _decoder(fm.JointStates)
POSE = _decoder(fm.PoseInFrame)


def _same(a: float, b: float) -> bool:
    return (math.isnan(a) and math.isnan(b)) or a == b


def _sdk_transforms(ns: int, transforms: list[Transform]) -> fm.FrameTransforms:
    ts = fm.Timestamp(sec=ns // 1_000_000_000, nsec=ns % 1_000_000_000)
    return fm.FrameTransforms(
        transforms=[
            fm.FrameTransform(
                timestamp=ts,
                parent_frame_id=t.parent,
                child_frame_id=t.child,
                translation=fm.Vector3(x=t.translation[0], y=t.translation[1], z=t.translation[2]),
                rotation=fm.Quaternion(x=t.rotation[0], y=t.rotation[1], z=t.rotation[2], w=t.rotation[3]),
            )
            for t in transforms
        ]
    )


numbers = st.floats(allow_nan=True, allow_infinity=True, width=64)
names = st.text(min_size=0, max_size=80)  # long ones: a frame's length needs a 2-byte varint
times = st.integers(min_value=0, max_value=2**32 * 10**9 - 1)  # the SDK keeps the seconds in 32 bits
transform = st.builds(
    Transform, names, names, st.tuples(numbers, numbers, numbers), st.tuples(numbers, numbers, numbers, numbers)
)


@pytest.mark.slow
@settings(max_examples=300, deadline=None)
@given(ns=times, transforms=st.lists(transform, max_size=20))
def test_frame_transforms_decode_as_the_sdks(ns, transforms):
    enc = FrameTransformsEncoder()
    ours = TF.FromString(enc.encode(ns, transforms))
    theirs = TF.FromString(_sdk_transforms(ns, transforms).encode())
    assert len(ours.transforms) == len(theirs.transforms) == len(transforms)
    for a, b, t in zip(ours.transforms, theirs.transforms, transforms):
        assert (a.timestamp.seconds, a.timestamp.nanos) == (b.timestamp.seconds, b.timestamp.nanos) == divmod(ns, 10**9)
        assert (a.parent_frame_id, a.child_frame_id) == (b.parent_frame_id, b.child_frame_id) == (t.parent, t.child)
        got = (
            a.translation.x,
            a.translation.y,
            a.translation.z,
            a.rotation.x,
            a.rotation.y,
            a.rotation.z,
            a.rotation.w,
        )
        want = (*t.translation, *t.rotation)
        sdk = (
            b.translation.x,
            b.translation.y,
            b.translation.z,
            b.rotation.x,
            b.rotation.y,
            b.rotation.z,
            b.rotation.w,
        )
        assert all(map(_same, got, want)) and all(map(_same, sdk, want))
    # the names are cached per (parent, child): a second message from the same encoder is the same
    assert enc.encode(ns, transforms) == FrameTransformsEncoder().encode(ns, transforms)


@pytest.mark.slow
@settings(max_examples=300, deadline=None)
@given(ns=times, data=st.data())
def test_joint_states_decode_as_the_sdks(ns, data):
    joint_names = data.draw(st.lists(names, max_size=12))
    n = len(joint_names)
    values = st.one_of(st.none(), st.lists(st.one_of(numbers, st.none()), min_size=0, max_size=n + 2))
    position, velocity, effort = data.draw(values), data.draw(values), data.draw(values)

    def val(seq, i):  # the SDK objects' values as the log gets them: a missing value is NaN
        return math.nan if seq is None or i >= len(seq) or seq[i] is None else float(seq[i])

    ours = JOINTS.FromString(JointStatesEncoder(joint_names).encode(ns, position, velocity, effort))
    sdk = fm.JointStates(
        timestamp=fm.Timestamp(sec=ns // 10**9, nsec=ns % 10**9),
        joints=[
            fm.JointState(name=name, position=val(position, i), velocity=val(velocity, i), effort=val(effort, i))
            for i, name in enumerate(joint_names)
        ],
    )
    theirs = JOINTS.FromString(sdk.encode())
    assert (ours.timestamp.seconds, ours.timestamp.nanos) == (theirs.timestamp.seconds, theirs.timestamp.nanos)
    assert [j.name for j in ours.joints] == [j.name for j in theirs.joints] == joint_names
    for a, b in zip(ours.joints, theirs.joints):
        assert all(
            map(
                _same,
                (a.position, a.velocity, a.effort, a.acceleration),
                (b.position, b.velocity, b.effort, b.acceleration),
            )
        )


@pytest.mark.slow
@settings(max_examples=300, deadline=None)
@given(ns=times, frame=names, t=transform)
def test_pose_in_frame_decodes_as_the_sdks(ns, frame, t):
    ours = POSE.FromString(pose_in_frame(ns, frame, t))
    sdk = fm.PoseInFrame(
        timestamp=fm.Timestamp(sec=ns // 10**9, nsec=ns % 10**9),
        frame_id=frame,
        pose=fm.Pose(
            position=fm.Vector3(x=t.translation[0], y=t.translation[1], z=t.translation[2]),
            orientation=fm.Quaternion(x=t.rotation[0], y=t.rotation[1], z=t.rotation[2], w=t.rotation[3]),
        ),
    )
    theirs = POSE.FromString(sdk.encode())
    assert (
        (ours.timestamp.seconds, ours.timestamp.nanos)
        == (theirs.timestamp.seconds, theirs.timestamp.nanos)
        == divmod(ns, 10**9)
    )
    assert ours.frame_id == theirs.frame_id == frame
    for msg in (ours, theirs):
        p, q = msg.pose.position, msg.pose.orientation
        assert all(map(_same, (p.x, p.y, p.z, q.x, q.y, q.z, q.w), (*t.translation, *t.rotation)))


def test_joint_states_take_numpy_arrays():
    import numpy as np

    msg = JOINTS.FromString(JointStatesEncoder(["j1", "j2"]).encode(5, np.array([0.5, -1.0]), np.zeros(2), None))
    assert [(j.name, j.position, j.velocity) for j in msg.joints] == [("j1", 0.5, 0.0), ("j2", -1.0, 0.0)]
    assert all(math.isnan(j.effort) for j in msg.joints)


def test_varint_matches_protobufs():
    from google.protobuf.internal import encoder

    for n in (0, 1, 127, 128, 300, 2**32, 2**63 - 1):
        out = []
        encoder._VarintEncoder()(out.append, n, True)  # noqa: SLF001 - protobuf's own varint, as the reference
        assert varint(n) == b"".join(out)
