"""The Reach System packet codec against known-good packets from public code
(alpha_driver test_packet.cpp / test_crc.cpp, pybravo test_protocol.py), and its
decoder against corrupted streams."""

from __future__ import annotations

import struct

import pytest
from crccheck.crc import Crc8Base
from hypothesis import given
from hypothesis import strategies as st

from hal.drivers.reach_protocol import (
    FrameDecoder,
    Packet,
    PacketError,
    PacketId,
    crc8,
    decode_frame,
    encode,
    encode_floats,
    encode_request,
)

#: A REQUEST (0x60) for the POSITION (0x03) of the jaw (device 0x01), as published.
REQUEST_JAW_POSITION = bytes([0x06, 0x03, 0x60, 0x01, 0x05, 0x52, 0x00])
#: Data 01 02 03 04, packet id 0x01, device 0xFF, as published.
DATA_1234_TO_ALL = bytes([0x09, 0x01, 0x02, 0x03, 0x04, 0x01, 0xFF, 0x08, 0x5D, 0x00])


class RocksoftInitFF(Crc8Base):
    """The issue's parameters read literally in the Rocksoft model: init 0xFF."""

    _poly = 0x4D
    _initvalue = 0xFF
    _reflect_input = True
    _reflect_output = True
    _xor_output = 0xFF


def test_published_packets_encode_and_decode() -> None:
    assert encode(0x01, PacketId.REQUEST, bytes([PacketId.POSITION])) == REQUEST_JAW_POSITION
    assert encode_request(0x01, [PacketId.POSITION]) == REQUEST_JAW_POSITION
    assert decode_frame(DATA_1234_TO_ALL[:-1]) == Packet(0xFF, 0x01, b"\x01\x02\x03\x04")
    assert encode(0xFF, 0x01, b"\x01\x02\x03\x04") == DATA_1234_TO_ALL


def test_crc_parameters_are_init_zero_not_rocksoft_init_ff() -> None:
    assert crc8(bytes([0xFF, 0x12, 0xAD, 0x23, 0x56])) == 0xF3  # alpha_driver test_crc.cpp
    # the published packets' CRC bytes (last byte before the delimiter, COBS leaves it as is here)
    for body, crc in ((bytes([0x03, 0x60, 0x01, 0x05]), 0x52), (bytes([1, 2, 3, 4, 0x01, 0xFF, 0x08]), 0x5D)):
        assert crc8(body) == crc
        assert RocksoftInitFF.calc(body) != crc  # "init 0xFF" as a Rocksoft parameter does not check


def test_floats_are_little_endian_float32() -> None:
    frame = encode_floats(0x03, PacketId.VELOCITY, [0.25])
    pkt = decode_frame(frame[:-1])
    assert pkt.data == struct.pack("<f", 0.25) and pkt.floats() == (0.25,)
    with pytest.raises(ValueError, match="not float32"):
        Packet(1, 2, b"\x00\x01\x02").floats()


@given(
    device=st.integers(0, 255),
    packet=st.integers(0, 255),
    data=st.binary(max_size=60),
)
def test_round_trip_and_only_one_zero(device: int, packet: int, data: bytes) -> None:
    frame = encode(device, packet, data)
    assert frame.count(0) == 1 and frame.endswith(b"\x00")
    assert decode_frame(frame[:-1]) == Packet(device, packet, data)


@given(data=st.binary(min_size=1, max_size=20), flip=st.integers(0, 7), at=st.integers(0, 200))
def test_any_single_bit_error_is_caught(data: bytes, flip: int, at: int) -> None:
    frame = bytearray(encode(0x02, PacketId.POSITION, data)[:-1])
    i = at % len(frame)
    frame[i] ^= 1 << flip
    if 0 in frame:
        return  # a zero would split the frame; the stream decoder test covers that
    with pytest.raises(PacketError):
        decode_frame(bytes(frame))


def test_decoder_counts_and_skips_bad_frames_and_keeps_partial_ones() -> None:
    dec = FrameDecoder()
    good = encode_floats(0x02, PacketId.POSITION, [1.5])
    bad_crc = bytearray(good)
    bad_crc[-2] ^= 0x01  # the CRC byte
    bad_cobs = bytes([0x09, 0x01, 0x02, 0x00])  # code 9 with only 2 bytes after it
    stream = good + bytes(bad_crc) + bad_cobs + good[:3]
    out = dec.feed(stream)
    assert [p.floats() for p in out] == [(1.5,)]
    assert dec.errors["crc"] == 1 and dec.errors["cobs"] == 1
    assert dec.feed(good[3:]) == [Packet(0x02, PacketId.POSITION, struct.pack("<f", 1.5))]
    assert dec.feed(b"\x01" * 500) == [] and dec.errors["overflow"] == 1
    assert dec.feed(b"\x00" + good) and dec.packets == 3
