"""Protobuf wire bytes of the Foxglove messages written at the 3D-view rate.

``/tf`` (``foxglove.FrameTransforms``) and ``/arm/joints`` (``foxglove.JointStates``)
are written every 3D-view sample (10 Hz in a run), ``/goal/vehicle`` and
``/goal/tool`` (``foxglove.PoseInFrame``) at such a sample when the KCL's
targets changed (about every other sample in the reference mission). Building them as
``foxglove-sdk`` message objects (one object per frame, vector, quaternion and
timestamp) and encoding those would be most of the sample's cost; the bytes are
simple, so they are written here with :mod:`struct`: a frame's two names are encoded once and cached, the
numbers of a frame go out in one ``struct.pack``.

The fields and their numbers are those of the SDK's schemas (the
``FileDescriptorSet`` the log carries for these channels; checked by
``tests/logs/test_protowire.py``, which decodes these bytes with the
``protobuf`` runtime and compares them with what the SDK's own objects give).
Unlike the SDK's encoder, every number is written even when it is 0.0 (a
reader cannot tell the difference: proto3 reads a missing number as 0.0);
``acceleration`` of a joint state is left out (0.0, as the SDK writes it when
not set).
"""

from __future__ import annotations

import math
import struct
from collections.abc import Iterable, Sequence

from mission.logs.frames import Transform

# wire types: 0 varint, 1 64-bit, 2 length-delimited
#: FrameTransform fields 4 (translation: Vector3 x, y, z) and 5 (rotation: Quaternion x, y, z, w).
_POSE = struct.Struct("<BB BdBdBd BB BdBdBdBd".replace(" ", ""))
_POSE_TAGS = (0x22, 27, 0x09, 0x11, 0x19, 0x2A, 36, 0x09, 0x11, 0x19, 0x21)
#: PoseInFrame field 3 (pose) holding Pose fields 1 (position) and 2 (orientation): the
#: layout of :data:`_POSE` (a Vector3 field, then a Quaternion field) after the pose's key and length.
_POSE_IN_FRAME = struct.Struct("<BB" + _POSE.format[1:])
#: JointState fields 2 (position), 3 (velocity), 5 (effort).
_JOINT = struct.Struct("<BdBdBd")


def varint(n: int) -> bytes:
    """Base-128 varint of a non-negative integer."""
    out = bytearray()
    while True:
        low = n & 0x7F
        n >>= 7
        if n:
            out.append(low | 0x80)
        else:
            out.append(low)
            return bytes(out)


def length_delimited(tag: int, payload: bytes) -> bytes:
    """Field ``tag`` (the key byte: field number << 3 | 2) holding ``payload``."""
    return bytes((tag,)) + varint(len(payload)) + payload


def timestamp_field(tag: int, ns: int) -> bytes:
    """A ``google.protobuf.Timestamp`` field of time ``ns`` (ns since the epoch, >= 0)."""
    sec, nsec = divmod(int(ns), 1_000_000_000)
    body = (b"\x08" + varint(sec) if sec else b"") + (b"\x10" + varint(nsec) if nsec else b"")
    return length_delimited(tag, body)


class FrameTransformsEncoder:
    """``foxglove.FrameTransforms`` bytes of a list of :class:`~mission.logs.frames.Transform`."""

    def __init__(self) -> None:
        self._names: dict[tuple[str, str], bytes] = {}
        #: a transform's key and length (field 1) by the length of its body
        self._heads: dict[int, bytes] = {}

    def _name_fields(self, parent: str, child: str) -> bytes:
        key = (parent, child)
        b = self._names.get(key)
        if b is None:
            b = self._names[key] = length_delimited(0x12, parent.encode()) + length_delimited(0x1A, child.encode())
        return b

    def encode(self, ns: int, transforms: Iterable[Transform]) -> bytes:
        """Every transform stamped ``ns`` (log time, ns); translation in m, rotation a
        quaternion (x, y, z, w). A transform goes out as four parts joined once at the
        end: its key and length, the stamp, its names (cached), its numbers."""
        stamp = timestamp_field(0x0A, ns)
        fixed = len(stamp) + _POSE.size
        names = self._names
        heads = self._heads
        pack = _POSE.pack
        t0, t1, a, b, c, r0, r1, d, e, f, g = _POSE_TAGS
        parts: list[bytes] = []
        for parent, child, (x, y, z), (qx, qy, qz, qw) in transforms:
            nf = names.get((parent, child))
            if nf is None:
                nf = self._name_fields(parent, child)
            n = fixed + len(nf)
            head = heads.get(n)
            if head is None:
                head = heads[n] = b"\x0a" + varint(n)
            parts += (head, stamp, nf, pack(t0, t1, a, x, b, y, c, z, r0, r1, d, qx, e, qy, f, qz, g, qw))
        return b"".join(parts)


def _values(seq: Sequence[float] | None, n: int) -> list[float]:
    """The first ``n`` numbers of ``seq`` as floats, NaN for a missing one (no ``seq``, a
    shorter one, or None in it)."""
    if seq is None:
        return [math.nan] * n
    values = seq.tolist() if hasattr(seq, "tolist") else list(seq)
    return [math.nan if x is None else float(x) for x in values[:n]] + [math.nan] * (n - len(values))


class JointStatesEncoder:
    """``foxglove.JointStates`` bytes: named joints (rad, rad/s; effort = motor current, A,
    as measured; a missing value is NaN, as :func:`mission.logs.wellknown.joint_states`)."""

    def __init__(self, names: Sequence[str]) -> None:
        self.names = [str(n) for n in names]
        #: per joint, what comes before its numbers: the key and length of its JointState
        #: field (the length is fixed: the name field and three numbers), then the name field
        self._heads = []
        for name in self.names:
            name_field = length_delimited(0x0A, name.encode())
            self._heads.append(b"\x12" + varint(len(name_field) + _JOINT.size) + name_field)

    def encode(
        self,
        ns: int,
        position: Sequence[float] | None,
        velocity: Sequence[float] | None,
        effort: Sequence[float] | None,
    ) -> bytes:
        heads = self._heads
        n = len(heads)
        pack = _JOINT.pack
        parts = [timestamp_field(0x0A, ns)]
        for head, p, v, e in zip(heads, _values(position, n), _values(velocity, n), _values(effort, n)):
            parts += (head, pack(0x11, p, 0x19, v, 0x29, e))
        return b"".join(parts)


def pose_in_frame(ns: int, frame: str, transform: Transform) -> bytes:
    """``foxglove.PoseInFrame`` bytes: the pose of ``transform`` (translation m, rotation a
    quaternion x y z w; its names are not used) in ``frame``, stamped ``ns`` (log time, ns)."""
    (x, y, z), (qx, qy, qz, qw) = transform.translation, transform.rotation
    pose = _POSE_IN_FRAME.pack(
        0x1A, 67, 0x0A, 27, 0x09, x, 0x11, y, 0x19, z, 0x12, 36, 0x09, qx, 0x11, qy, 0x19, qz, 0x21, qw
    )
    return timestamp_field(0x0A, ns) + length_delimited(0x12, frame.encode()) + pose
