"""Water Linked DVL and MicroStrain AHRS: byte formats, and drivers against
simulator processes over 127.0.0.1 TCP and pseudo-terminals."""

from __future__ import annotations

import struct

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from hal.drivers.ahrs_microstrain import MicrostrainAhrs, MipParser, ahrs_packet, build_packet, mip_checksum
from hal.drivers.dvl_waterlinked import DvlParseError, WaterLinkedDvl, crc8, format_wrz, parse_json_line, parse_wrz_line
from hal.drivers.realtime import MonotonicClock
from hal.interfaces import HealthState
from hal.testing.peers import Peer, wait_until

# ----------------------------------------------------------------------------- DVL formats


def test_crc8_check_value() -> None:
    assert crc8(b"123456789") == 0xF4  # CRC-8 (poly 0x07) catalogue check value
    assert crc8(b"") == 0


def test_wrz_roundtrip_and_invalid_flag() -> None:
    rep = parse_wrz_line(format_wrz(0.12, -0.034, 0.005, True, 2.5, fom=0.003) + "\r\n")
    assert np.allclose(rep.velocity, [0.12, -0.034, 0.005]) and rep.altitude == 2.5 and rep.fom == pytest.approx(0.003)
    rep = parse_wrz_line(format_wrz(0.0, 0.0, 0.0, False, -1.0))
    assert rep.velocity is None and rep.altitude is None
    assert parse_wrz_line("wrp,1,2,3*00") is None  # another sentence


def test_wrz_checksum_is_two_lowercase_hex_digits() -> None:
    body = format_wrz(0.1, 0.2, -0.05, True, 3.0).rpartition("*")[0]
    cs = f"{crc8(body.encode()):02x}"
    assert parse_wrz_line(f"{body}*{cs}") is not None
    for bad in (f"{int(cs, 16):02X}", f"+{cs[1]}", f" {cs[1]}"):
        if bad != cs:
            with pytest.raises(DvlParseError):
                parse_wrz_line(f"{body}*{bad}")


@settings(max_examples=100, deadline=None)
@given(pos=st.integers(min_value=0), ch=st.characters(min_codepoint=32, max_codepoint=126))
def test_any_single_character_change_in_wrz_is_rejected(pos: int, ch: str) -> None:
    line = format_wrz(0.1, 0.2, -0.05, True, 3.0)
    i = pos % len(line)
    mutated = line[:i] + ch + line[i + 1 :]
    if mutated == line:
        return
    try:
        rep = parse_wrz_line(mutated)
    except DvlParseError:
        return
    assert rep is None and not mutated.startswith("wrz")  # only a changed sentence id escapes parsing


@pytest.mark.parametrize(
    ("line", "kind"),
    [
        ('{"type": "velocity", "vx": 0.1, "vy"', "format"),
        ('{"type": "velocity", "vx": 0.1}', "format"),
        ('{"type": "velocity", "vx": 55.0, "vy": 0, "vz": 0, "velocity_valid": true}', "absurd"),
        ('{"type": "velocity", "vx": NaN, "vy": 0, "vz": 0, "velocity_valid": true}', "absurd"),
        ("[1, 2]", "format"),
    ],
)
def test_bad_json_lines_are_rejected(line: str, kind: str) -> None:
    with pytest.raises(DvlParseError) as exc:
        parse_json_line(line)
    assert exc.value.kind == kind


def test_json_velocity_and_other_reports() -> None:
    rep = parse_json_line(
        '{"type": "velocity", "vx": 0.1, "vy": -0.2, "vz": 0.0, "fom": 0.01, "altitude": 4.2, "velocity_valid": true, "status": 0}'
    )
    assert np.allclose(rep.velocity, [0.1, -0.2, 0.0]) and rep.altitude == 4.2
    assert parse_json_line('{"type": "position_local", "x": 1, "y": 2, "z": 3}') is None


# ----------------------------------------------------------------------------- MIP format


def test_mip_packet_layout_and_checksum() -> None:
    pkt = build_packet(0x80, [(0x0C, struct.pack(">3f", 0.1, 0.2, 0.3))])
    assert pkt[:4] == bytes([0x75, 0x65, 0x80, 14]) and pkt[4:6] == bytes([14, 0x0C])
    a = b = 0
    for byte in pkt[:-2]:
        a = (a + byte) % 256
        b = (b + a) % 256
    assert pkt[-2:] == bytes([a, b]) == mip_checksum(pkt[:-2])


@settings(max_examples=60, deadline=None)
@given(cuts=st.lists(st.integers(min_value=0, max_value=200), max_size=6), junk=st.binary(max_size=20))
def test_mip_parser_survives_any_chunking_and_junk(cuts: list[int], junk: bytes) -> None:
    packets = [ahrs_packet((0.1 * i, -0.1, 0.5), (0.0, 0.01, 0.02)) for i in range(3)]
    bad = bytearray(packets[1])
    bad[-1] ^= 0xFF
    stream = junk.replace(b"\x75", b"") + packets[0] + bytes(bad) + packets[2]
    parser = MipParser()
    got = []
    prev = 0
    for c in sorted({min(c, len(stream)) for c in cuts}) + [len(stream)]:
        got += parser.feed(stream[prev:c])
        prev = c
    eulers = [struct.unpack(">3f", p.fields[0x0C])[0] for p in got]
    assert eulers == pytest.approx([0.0, 0.2], abs=1e-6)
    assert parser.bad_checksums >= 1


# ----------------------------------------------------------------------------- drivers vs. simulator processes


def dvl_params(**kw: object) -> dict:
    return {
        "transport": "tcp",
        "host": "127.0.0.1",
        "port": 16171,
        "device": None,
        "baudrate": 115200,
        "timeout": 0.3,
        **kw,
    }


@pytest.mark.peer
def test_dvl_tcp_json_with_corrupt_lines_and_lost_link() -> None:
    sim = Peer("hal.testing.nav_sensor_sim", "dvl-tcp", "--rate", "20", "--velocity", "0.25,-0.1,0.05")
    dvl = WaterLinkedDvl(dvl_params(port=int(sim.ready)), MonotonicClock().now, mounting_rpy=(0.0, 0.0, np.pi / 2))
    try:
        dvl.connect()
        assert wait_until(lambda: dvl.health().state == HealthState.OK, 3.0), dvl.health()
        v, _ = dvl.velocity()
        assert np.allclose(v, [0.1, 0.25, 0.05], atol=1e-9)  # DVL x along vehicle y (mounted yawed 90 deg)
        assert dvl.altitude()[0] == pytest.approx(3.0)
        assert wait_until(lambda: dvl.health().info["rate_hz"] > 10, 2.0)
        for kind in ("json", "absurd", "garbage"):
            sim.send(cmd="corrupt", kind=kind)
        assert wait_until(lambda: dvl.rejected["format"] >= 2 and dvl.rejected["absurd"] >= 1, 2.0), dvl.rejected
        h = dvl.health()
        assert h.state == HealthState.DEGRADED and "rejected lines" in h.detail
        assert np.allclose(dvl.velocity()[0], [0.1, 0.25, 0.05])  # never the absurd value
        sim.send(cmd="invalid")
        sim.send(cmd="silence")
        assert wait_until(lambda: dvl.health().state == HealthState.FAULT, 2.0)
        assert "stale velocity" in dvl.health().detail
        sim.stop()  # the DVL goes away: the link is reported lost, the reader keeps retrying
        assert wait_until(
            lambda: "link to 127.0.0.1" in dvl.health().detail or "cannot open" in dvl.health().detail, 3.0
        ), dvl.health()
        assert dvl.health().state == HealthState.FAULT
    finally:
        dvl.close()
        sim.stop()


@pytest.mark.peer
def test_dvl_serial_wrz_crc_errors_and_port_disappearing() -> None:
    sim = Peer("hal.testing.nav_sensor_sim", "dvl-serial", "--rate", "20")
    dvl = WaterLinkedDvl(dvl_params(transport="serial", device=sim.ready), MonotonicClock().now)
    try:
        dvl.connect()
        assert wait_until(lambda: dvl.health().state == HealthState.OK, 3.0), dvl.health()
        assert np.allclose(dvl.velocity()[0], [0.2, 0.0, 0.05])
        sim.send(cmd="corrupt", kind="crc")
        assert wait_until(lambda: dvl.rejected["crc"] == 1, 2.0), dvl.rejected
        assert "CRC-8 mismatch" in dvl.health().detail
        sim.stop()  # pty master closed: the serial port disappears under the reader
        assert wait_until(lambda: dvl.health().state == HealthState.FAULT, 3.0)
        assert wait_until(
            lambda: "serial port lost" in dvl.health().detail or "cannot open" in dvl.health().detail, 3.0
        ), dvl.health()
    finally:
        dvl.close()
        sim.stop()


@pytest.mark.peer
def test_ahrs_mip_over_pty_with_bad_checksums_and_port_loss() -> None:
    sim = Peer("hal.testing.nav_sensor_sim", "ahrs-serial", "--rate", "50")
    ahrs = MicrostrainAhrs({"device": sim.ready, "baudrate": 115200, "timeout": 0.3}, MonotonicClock().now)
    try:
        ahrs.connect()
        assert wait_until(lambda: ahrs.health().state == HealthState.OK, 3.0), ahrs.health()
        rpy, rates, t = ahrs.attitude()
        assert rpy[:2] == pytest.approx([0.01, -0.02], abs=1e-6) and rates[2] == pytest.approx(0.1, abs=1e-6)
        assert wait_until(lambda: ahrs.health().info["rate_hz"] > 25, 2.0), ahrs.health()
        sim.send(cmd="corrupt", kind="crc")
        sim.send(cmd="corrupt", kind="absurd")
        assert wait_until(lambda: ahrs.parser.bad_checksums >= 1 and ahrs.rejected >= 1, 2.0)
        assert abs(ahrs.attitude()[0][2]) < 3.2  # the absurd yaw was not taken
        sim.stop()
        assert wait_until(lambda: ahrs.health().state == HealthState.FAULT, 3.0)
        assert "AHRS:" in ahrs.health().detail
    finally:
        ahrs.close()
        sim.stop()


@pytest.mark.peer
@pytest.mark.slow
def test_dvl_tcp_reconnects_after_the_dvl_restarts() -> None:
    sim = Peer("hal.testing.nav_sensor_sim", "dvl-tcp", "--rate", "20")
    port = int(sim.ready)
    dvl = WaterLinkedDvl(dvl_params(port=port), MonotonicClock().now)
    try:
        dvl.connect()
        assert wait_until(lambda: dvl.health().state == HealthState.OK, 3.0), dvl.health()
        sim.stop()
        assert wait_until(lambda: dvl.health().state == HealthState.FAULT, 3.0)
        sim = Peer("hal.testing.nav_sensor_sim", "dvl-tcp", "--rate", "20", "--port", str(port))
        assert wait_until(lambda: dvl.health().state == HealthState.OK, 5.0), dvl.health()
    finally:
        dvl.close()
        sim.stop()


_json = st.recursive(
    st.one_of(st.none(), st.booleans(), st.integers(), st.floats(), st.text(max_size=5)),
    lambda inner: st.one_of(st.lists(inner, max_size=3), st.dictionaries(st.text(max_size=5), inner, max_size=3)),
    max_leaves=10,
)


@pytest.mark.slow
@settings(max_examples=100, deadline=None)
@given(
    fields=st.dictionaries(
        st.sampled_from(["type", "vx", "vy", "vz", "fom", "altitude", "velocity_valid", "status"]), _json
    ),
    text=st.text(max_size=40),
)
def test_dvl_parsers_only_ever_reject_cleanly(fields: dict, text: str) -> None:
    import json

    for parse, line in (
        (parse_json_line, json.dumps({"type": "velocity", **fields})),
        (parse_json_line, text),
        (parse_wrz_line, "wrz," + text),
    ):
        try:
            rep = parse(line)
        except DvlParseError:
            continue
        assert rep is None or rep.velocity is None or np.all(np.isfinite(rep.velocity))
