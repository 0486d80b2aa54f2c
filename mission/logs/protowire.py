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

    def _name_fields(self, parent: str, child: str) -> bytes:
        key = (parent, child)
        b = self._names.get(key)
        if b is None:
            b = self._names[key] = length_delimited(0x12, parent.encode()) + length_delimited(0x1A, child.encode())
        return b

    def encode(self, ns: int, transforms: Iterable[Transform]) -> bytes:
        """Every transform stamped ``ns`` (log time, ns); translation in m, rotation a
        quaternion (x, y, z, w)."""
        stamp = timestamp_field(0x0A, ns)
        names = self._names
        pack = _POSE.pack
        t0, t1, a, b, c, r0, r1, d, e, f, g = _POSE_TAGS
        parts = []
        for tr in transforms:
            key = (tr.parent, tr.child)
            nf = names.get(key)
            if nf is None:
                nf = self._name_fields(tr.parent, tr.child)
            (x, y, z), (qx, qy, qz, qw) = tr.translation, tr.rotation
            body = stamp + nf + pack(t0, t1, a, x, b, y, c, z, r0, r1, d, qx, e, qy, f, qz, g, qw)
            n = len(body)
            parts.append((b"\x0a" + bytes((n,)) if n < 128 else b"\x0a" + varint(n)) + body)
        return b"".join(parts)


def _as_list(seq: Sequence[float] | None) -> list | None:
    if seq is None:
        return None
    return seq.tolist() if hasattr(seq, "tolist") else list(seq)


def _number(seq: list | None, i: int) -> float:
    if seq is None or i >= len(seq) or seq[i] is None:
        return math.nan
    return float(seq[i])


class JointStatesEncoder:
    """``foxglove.JointStates`` bytes: named joints (rad, rad/s; effort = motor current, A,
    as measured; a missing value is NaN, as :func:`mission.logs.wellknown.joint_states`)."""

    def __init__(self, names: Sequence[str]) -> None:
        self.names = [str(n) for n in names]
        self._name_fields = [length_delimited(0x0A, n.encode()) for n in self.names]

    def encode(
        self,
        ns: int,
        position: Sequence[float] | None,
        velocity: Sequence[float] | None,
        effort: Sequence[float] | None,
    ) -> bytes:
        pos, vel, eff = _as_list(position), _as_list(velocity), _as_list(effort)
        pack = _JOINT.pack
        parts = [timestamp_field(0x0A, ns)]
        for i, nf in enumerate(self._name_fields):
            body = nf + pack(0x11, _number(pos, i), 0x19, _number(vel, i), 0x29, _number(eff, i))
            parts.append(length_delimited(0x12, body))
        return b"".join(parts)


def pose_in_frame(ns: int, frame: str, transform: Transform) -> bytes:
    """``foxglove.PoseInFrame`` bytes: the pose of ``transform`` (translation m, rotation a
    quaternion x y z w; its names are not used) in ``frame``, stamped ``ns`` (log time, ns)."""
    (x, y, z), (qx, qy, qz, qw) = transform.translation, transform.rotation
    pose = _POSE_IN_FRAME.pack(
        0x1A, 67, 0x0A, 27, 0x09, x, 0x11, y, 0x19, z, 0x12, 36, 0x09, qx, 0x11, qy, 0x19, qz, 0x21, qw
    )
    return timestamp_field(0x0A, ns) + length_delimited(0x12, frame.encode()) + pose
