"""The Reach System serial protocol (Reach Robotics Alpha 5 / Bravo 7 arms): packets,
their checksum and framing, written from the public documentation and code.

A packet on the wire, before framing::

    data (0..n bytes) | packet id (1) | device id (1) | length = n + 4 (1) | CRC-8 (1)

COBS-encoded (the maintained ``cobs`` package) and ended by one 0x00 byte, the
only zero on the wire. Floats are IEEE 754 32-bit little-endian. Units: rad and
rad/s for rotary joints, mm and mm/s for the linear jaw, **mA** for currents.
Devices are addressed by id: 0x01 is the jaw, 0x02.. the joints from the wrist
towards the base (Alpha 5: 0x02-0x05, Bravo 7: 0x02-0x07); 0xFF reaches all.

**The CRC-8**, the check of this module that matters most: polynomial 0x4D
(0x14D with the x^8 term written out), input and output reflected, register
initialised to 0x00, result XORed with 0xFF. The sources say this in two
notations that look contradictory. Reach's older Python SDK (``bplprotocol``)
builds its CRC with ``crcmod.mkCrcFun(0x14D, initCrc=0xFF, xorOut=0xFF)``, and
crcmod's ``initCrc`` is the register start value *XORed with* ``xorOut``
(crcmod's documented convention; its ``rev`` defaults to reflected): 0xFF ^ 0xFF
= 0x00. The Robotic Decision Making Lab's ``alpha_driver`` (crc.hpp) and
``pybravo`` (packet.py) state the same CRC in the Rocksoft model that most CRC
libraries (``crccheck`` here) take: poly 0x4D, init 0x00, reflected, xor-out
0xFF. Read literally as Rocksoft parameters, "init 0xFF" gives a different CRC.
The known-good packets published with that code settle it: ``06 03 60 01 05 52
00`` (a request for the jaw's position), ``09 01 02 03 04 01 FF 08 5D 00`` and
the CRC 0xF3 of ``FF 12 AD 23 56`` check with init 0x00 and fail with a
Rocksoft init of 0xFF (tests/hal/test_reach_protocol.py checks all three, both
ways).

What the packet ids and modes mean comes from Reach's SDK (``rs_protocol``
packetID.py / mode.py, ``bplprotocol`` packetID.py docstrings) and the
``alpha_driver`` enums; see :class:`PacketId` and :class:`Mode`.
"""

from __future__ import annotations

import enum
import struct
from dataclasses import dataclass, field

from cobs import cobs
from crccheck.crc import Crc8Base

#: Device id that every device on the link answers to.
ALL_DEVICES = 0xFF
#: Device id of the jaw (gripper) on Alpha and Bravo arms.
JAW_DEVICE = 0x01
#: Bytes of a packet besides its data: packet id, device id, length, CRC.
TRAILER = 4
#: Longest data field the SDK encodes (its DATA_BYTES_PER_PACKET).
MAX_DATA = 60
#: Longest frame kept while waiting for its 0x00 delimiter; longer is garbage.
MAX_FRAME = 2 * (MAX_DATA + TRAILER)


class PacketId(enum.IntEnum):
    """Packet ids used here (rs_protocol packetID.py; bplprotocol packetID.py)."""

    MODE = 0x01  # 1 byte: a Mode
    VELOCITY = 0x02  # 1 float: rad/s, mm/s for the jaw
    POSITION = 0x03  # 1 float: rad, mm for the jaw
    CURRENT = 0x05  # 1 float: mA
    POSITION_LIMITS = 0x10  # 2 floats: maximum, minimum
    VELOCITY_LIMITS = 0x11  # 2 floats: maximum, minimum
    CURRENT_LIMITS = 0x12  # 2 floats: maximum, minimum (mA)
    REQUEST = 0x60  # bytes: the packet ids the device is to send back
    SERIAL_NUMBER = 0x61  # 1 float
    MODEL_NUMBER = 0x62  # 1 float
    TEMPERATURE = 0x66  # 1 float, degrees C
    HARDWARE_STATUS = 0x68  # 32-bit field of hardware error flags
    SOFTWARE_VERSION = 0x6C  # 3 bytes
    VOLTAGE = 0x90  # 1 float, V
    HEARTBEAT_SET = 0x91  # up to 10 bytes: packet ids the device streams
    HEARTBEAT_FREQUENCY = 0x92  # 1 byte: streaming rate in Hz (0-255)


#: Packet ids whose data are float32 values.
FLOAT_PACKETS = frozenset(
    {
        PacketId.VELOCITY,
        PacketId.POSITION,
        PacketId.CURRENT,
        PacketId.POSITION_LIMITS,
        PacketId.VELOCITY_LIMITS,
        PacketId.CURRENT_LIMITS,
        PacketId.SERIAL_NUMBER,
        PacketId.MODEL_NUMBER,
        PacketId.TEMPERATURE,
        PacketId.VOLTAGE,
    }
)
#: Most packet ids a HEARTBEAT_SET can list.
HEARTBEAT_SLOTS = 10


class Mode(enum.IntEnum):
    """Device modes (rs_protocol mode.py). A demand packet (VELOCITY, POSITION,
    CURRENT) puts a device that is not DISABLED into that demand's mode."""

    STANDBY = 0x00
    DISABLED = 0x01
    POSITION = 0x02
    VELOCITY = 0x03
    CURRENT = 0x04
    INDEXED_RELATIVE_POSITION = 0x13
    POSITION_PRESET = 0x14
    ZERO_VELOCITY = 0x15
    KINEMATIC_POSITION_BASE_FRAME = 0x17
    KINEMATIC_VELOCITY_BASE_FRAME = 0x18
    KINEMATIC_VELOCITY_END_EFFECTOR_FRAME = 0x1A
    POSITION_VELOCITY = 0x1C
    POSITION_HOLD = 0x1D
    PASSIVE = 0x26


def mode_name(value: int) -> str:
    """A mode byte as text (``VELOCITY``, or ``0x2A`` for an unknown one)."""
    try:
        return Mode(value).name
    except ValueError:
        return f"0x{value:02X}"


class ReachCrc8(Crc8Base):
    """The protocol's CRC-8 (see the module docstring): poly 0x4D, reflected, init 0x00, xor-out 0xFF."""

    _poly = 0x4D
    _initvalue = 0x00
    _reflect_input = True
    _reflect_output = True
    _xor_output = 0xFF


def crc8(data: bytes) -> int:
    """CRC-8 of ``data`` as the protocol computes it."""
    return int(ReachCrc8.calc(data))


@dataclass(frozen=True)
class Packet:
    """One decoded packet: who sent it (or is addressed), what it is, its data bytes."""

    device_id: int
    packet_id: int
    data: bytes

    def floats(self) -> tuple[float, ...]:
        """The data as float32 little-endian values (ValueError if not a multiple of 4 bytes)."""
        if len(self.data) % 4:
            raise ValueError(f"packet 0x{self.packet_id:02X}: {len(self.data)} data bytes are not float32 values")
        return struct.unpack(f"<{len(self.data) // 4}f", self.data)


class PacketError(ValueError):
    """A frame that is not a packet; ``kind`` is ``cobs``, ``crc`` or ``length``."""

    def __init__(self, kind: str, message: str) -> None:
        super().__init__(message)
        self.kind = kind


def encode(device_id: int, packet_id: int, data: bytes = b"") -> bytes:
    """One framed packet: COBS-encoded, 0x00-terminated."""
    if not 0 <= device_id <= 0xFF or not 0 <= packet_id <= 0xFF:
        raise ValueError(f"device id {device_id} / packet id {packet_id} must be bytes")
    if len(data) > MAX_DATA:
        raise ValueError(f"{len(data)} data bytes, at most {MAX_DATA}")
    body = bytes(data) + bytes((packet_id, device_id, len(data) + TRAILER))
    return bytes(cobs.encode(body + bytes((crc8(body),)))) + b"\x00"


def encode_floats(device_id: int, packet_id: int, values: tuple[float, ...] | list[float]) -> bytes:
    """A packet whose data are float32 little-endian values."""
    return encode(device_id, packet_id, struct.pack(f"<{len(values)}f", *values))


def encode_request(device_id: int, packet_ids: tuple[int, ...] | list[int]) -> bytes:
    """A REQUEST for the given packet ids (the device answers with one packet each)."""
    return encode(device_id, PacketId.REQUEST, bytes(packet_ids))


def decode_frame(frame: bytes) -> Packet:
    """A packet from one frame (without its 0x00 delimiter); PacketError if it is not one."""
    try:
        raw = bytes(cobs.decode(frame))
    except cobs.DecodeError as exc:
        raise PacketError("cobs", f"COBS decoding failed: {exc}") from None
    if len(raw) < TRAILER:
        raise PacketError("length", f"{len(raw)} bytes, shorter than a packet")
    body, crc = raw[:-1], raw[-1]
    if crc8(body) != crc:
        raise PacketError("crc", f"CRC 0x{crc:02X}, computed 0x{crc8(body):02X}")
    if raw[-2] != len(raw):
        raise PacketError("length", f"length byte {raw[-2]} for a {len(raw)}-byte packet")
    return Packet(device_id=raw[-3], packet_id=raw[-4], data=raw[:-4])


@dataclass
class FrameDecoder:
    """Splits a byte stream into packets at the 0x00 delimiters. Frames that do not
    decode are counted by kind in :attr:`errors` and skipped, never raised."""

    errors: dict[str, int] = field(default_factory=lambda: {"cobs": 0, "crc": 0, "length": 0, "overflow": 0})
    #: The last error's text, for health reports.
    last_error: str | None = None
    packets: int = 0
    _pending: bytearray = field(default_factory=bytearray)

    def feed(self, chunk: bytes) -> list[Packet]:
        """Packets completed by ``chunk`` (a partial frame waits for the next chunk)."""
        out: list[Packet] = []
        if not chunk:
            return out
        *frames, rest = (bytes(self._pending) + chunk).split(b"\x00")
        for frame in frames:
            if not frame:
                continue  # back-to-back delimiters (line idle, or a resynchronisation)
            try:
                out.append(decode_frame(frame))
            except PacketError as exc:
                self.errors[exc.kind] += 1
                self.last_error = f"{exc.kind}: {exc}"
        if len(rest) > MAX_FRAME:
            self.errors["overflow"] += 1
            self.last_error = f"overflow: {len(rest)} bytes without a delimiter dropped"
            rest = b""
        self._pending = bytearray(rest)
        self.packets += len(out)
        return out

    def reset(self) -> None:
        """Forget a partial frame (after the link was reopened)."""
        self._pending.clear()
