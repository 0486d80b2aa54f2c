"""The BlueROV2's camera path: RTP (RFC 3550) carrying H.264 (RFC 6184) into
the monocular pipe detector. The depacketizer's properties on its own; then
the driver against the stream peer in another process (x264-encoded rendered
frames sent as RTP to 127.0.0.1, as the vehicle's companion sends its camera)."""

from __future__ import annotations

import random
import struct
import time
from collections.abc import Iterator
from pathlib import Path

import cv2
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from hal.drivers.mono_detector import MonoPipeDetector
from hal.drivers.realtime import MonotonicClock
from hal.drivers.rtp_h264 import FU_A, STAP_A, H264Depacketizer, RtpError, parse_rtp
from hal.interfaces import HealthState
from hal.testing.peers import Peer, free_udp_port, peer_report, wait_until
from hal.testing.rtp_camera_peer import payloads

IDR, SPS, PPS, SLICE = 0x65, 0x67, 0x68, 0x41  # NAL headers (NRI 3 or 2, types 5, 7, 8, 1)


def rtp(seq: int, ts: int, payload: bytes, marker: bool = False, ssrc: int = 7, pt: int = 96) -> bytes:
    return struct.pack("!BBHII", 0x80, (0x80 if marker else 0) | pt, seq & 0xFFFF, ts, ssrc) + payload


def frame_packets(nals: list[bytes], seq: int, ts: int, mtu: int) -> list[bytes]:
    parts = payloads(nals, mtu - 12)
    return [rtp(seq + k, ts, body, k == len(parts) - 1) for k, (_kind, body) in enumerate(parts)]


def nal(header: int, size: int, rng: random.Random) -> bytes:
    return bytes([header]) + bytes(rng.randrange(1, 256) for _ in range(size - 1))


def test_rtp_header_fields_csrc_extension_and_padding_are_read_as_rfc_3550_lays_them_out() -> None:
    body = b"\x41abc"
    packet = struct.pack("!BBHII", 0x80 | 0x20 | 0x10 | 2, 0x80 | 96, 65535, 1234, 99)
    packet += b"CSR1CSR2" + struct.pack("!HH", 0xBEDE, 1) + b"EXT1" + body + b"\x00\x00\x03"
    p = parse_rtp(packet)
    assert (p.marker, p.payload_type, p.seq, p.timestamp, p.ssrc, p.payload) == (True, 96, 65535, 1234, 99, body)
    with pytest.raises(RtpError):
        parse_rtp(b"\x40" + bytes(20))  # version 1
    with pytest.raises(RtpError):
        parse_rtp(bytes(8))


def test_a_stap_a_and_fu_a_fragments_give_back_the_nal_units() -> None:
    rng = random.Random(0)
    sps, pps, idr = nal(SPS, 12, rng), nal(PPS, 5, rng), nal(IDR, 4000, rng)
    packets = frame_packets([sps, pps, idr], 100, 9000, 1400)
    kinds = [p[12] & 0x1F for p in packets]
    assert kinds[0] == STAP_A and all(k == FU_A for k in kinds[1:]) and len(packets) == 4  # 4000 B in 1386 B pieces
    d = H264Depacketizer()
    units = [u for p in packets for u in d.push(p, 0.0)]
    assert len(units) == 1 and units[0].nals == [sps, pps, idr] and units[0].timestamp == 9000
    assert units[0].annexb() == b"".join(b"\x00\x00\x00\x01" + n for n in (sps, pps, idr))


@settings(max_examples=60, deadline=None)
@given(
    sizes=st.lists(st.integers(1, 5000), min_size=1, max_size=12),
    mtu=st.integers(200, 1500),
    seq0=st.integers(0, 65535),
    seed=st.integers(0, 2**16),
)
def test_frames_survive_reordering_within_the_window_and_wrapping_sequence_numbers(
    sizes: list[int], mtu: int, seq0: int, seed: int
) -> None:
    """Any frames, split at any MTU, sent with neighbours swapped: every frame comes
    out whole and in order; the sequence numbers may wrap past 65535."""
    rng = random.Random(seed)
    frames = [[nal(SPS, 10, rng), nal(PPS, 4, rng), nal(IDR, sizes[0], rng)]]
    frames += [[nal(SLICE, s, rng)] for s in sizes[1:]]
    packets: list[bytes] = []
    for i, nals in enumerate(frames):
        packets += frame_packets(nals, seq0 + len(packets), 3000 * i, mtu)
    for i in range(1, len(packets) - 1, 3):  # the first one received starts the stream: it comes first
        if rng.random() < 0.5:
            packets[i], packets[i + 1] = packets[i + 1], packets[i]
    d = H264Depacketizer()
    units = [u for p in packets for u in d.push(p, 0.0)]
    assert [u.nals for u in units] == frames
    assert d.counters.lost == 0 and d.counters.frames_dropped == 0


def test_a_lost_packet_drops_its_frame_and_the_next_ones_until_an_idr() -> None:
    rng = random.Random(1)
    head = [nal(SPS, 10, rng), nal(PPS, 4, rng)]
    frames = [head + [nal(IDR, 3000, rng)], [nal(SLICE, 3000, rng)], [nal(SLICE, 200, rng)]]
    frames += [head + [nal(IDR, 3000, rng)], [nal(SLICE, 200, rng)]]
    per_frame = [frame_packets(f, 0, 0, 1400) for f in frames]  # sequence numbers set below
    packets, seq = [], 10
    for i, ps in enumerate(per_frame):
        for p in ps:
            packets.append(rtp(seq, 3000 * i, p[12:], bool(p[1] & 0x80)))
            seq += 1
    lost = len(per_frame[0]) + 1  # the second fragment of frame 1
    d = H264Depacketizer(reorder_s=0.0)
    units = [u for k, p in enumerate(packets) if k != lost for u in d.push(p, 0.01 * k)]
    assert [u.timestamp for u in units] == [0, 9000, 12000]  # frames 1 and 2 dropped, from the IDR of 3 on
    assert d.counters.lost == 1 and d.counters.frames_dropped == 2
    # a receiver starting mid-stream: nothing until the IDR that follows
    d = H264Depacketizer()
    start = len(per_frame[0]) + 2
    units = [u for k, p in enumerate(packets[start:]) for u in d.push(p, 0.0)]
    assert [u.timestamp for u in units] == [9000, 12000]


# ---------------------------------------------------------------------- against the stream peer

CAMERA = {"width": 646, "height": 482}


@pytest.fixture(scope="module")
def rendered(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, dict, list[np.ndarray]]:
    """A rendered view of the pipe 1.3 m away (the simulator's renderer, the camera still)
    as the stream's image, the camera's intrinsics and the true grasp point in the camera frame (m)."""
    from sim_backend.render_cases import view_case  # the renderer (Numba kernels) only for the peer tests

    folder = tmp_path_factory.mktemp("frames")
    case = view_case(1.3, seed=1, aim_offset_m=0.3)
    cv2.imwrite(str(folder / "000.png"), case.left)
    truths = [case.cam_T_grasp[:3, 3]]
    K, D = case.calib.left.K, case.calib.left.D
    cam = {**CAMERA, "fx": K[0, 0], "fy": K[1, 1], "cx": K[0, 2], "cy": K[1, 2], "distortion": D.tolist()}
    return folder, cam, truths


def detector(cam: dict, port: int, stale: float = 0.6) -> MonoPipeDetector:
    params = {
        "stream": {"port": port, "bind": "127.0.0.1", "payload_type": 96},
        "camera": cam,
        "stale_timeout_s": stale,
        "rate_hz": 10.0,
        "pipe": {"radius_m": 0.05, "length_m": 1.0},
        "log_frames_hz": 1.0,
    }
    return MonoPipeDetector(params, MonotonicClock().now)


@pytest.fixture
def stream(rendered: tuple[Path, dict, list[np.ndarray]]) -> Iterator[tuple[MonoPipeDetector, Peer, list]]:
    folder, cam, truths = rendered
    port = free_udp_port()
    det = detector(cam, port)
    det.connect()
    peer = Peer("hal.testing.rtp_camera_peer", "--images", str(folder), "--port", str(port), "--fps", "10")
    yield det, peer, truths
    peer.stop()
    det.disconnect()


@pytest.mark.peer
def test_frames_are_decoded_and_the_pipe_detected_then_a_killed_stream_is_caught(
    stream: tuple[MonoPipeDetector, Peer, list],
) -> None:
    det, peer, truths = stream
    assert wait_until(lambda: det.worker.detections >= 8, 8.0), det.health()
    h = det.health()
    assert h.state == HealthState.OK, h
    cam = next(p for p in h.info["parts"] if p["name"] == "camera")
    assert cam["resolution"] == "646x482" and cam["lost"] == 0 and cam["decode_errors"] == 0
    assert cam["fps"] == pytest.approx(10.0, rel=0.3)
    found = det.latest()
    assert found is not None and found.confidence > 0.3
    grasp = np.asarray(found.details["cam_T_grasp"])[:3, 3]  # the last accepted detection (camera frame)
    assert float(np.linalg.norm(grasp - truths[0])) < 0.03  # the monocular depth: about 1 cm here
    assert det.worker.detections >= 0.8 * det.worker.processed, (
        det.worker.detections,
        det.worker.processed,
    )  # every frame shows the pipe
    frames = det.camera_frames()
    assert frames and frames[-1].jpeg[:2] == b"\xff\xd8" and frames[-1].frame_id == "stereo_camera"
    rep = peer_report(peer)
    assert rep["fu-a"] > rep["frames"] and rep["stap-a"] == rep["keyframes"]  # SPS+PPS aggregated at each IDR
    peer.proc.kill()  # the stream dies: the camera's frames stop
    t_kill = time.monotonic()
    assert wait_until(lambda: det.health().state == HealthState.FAULT, 3.0)
    assert time.monotonic() - t_kill < 0.6 + 0.5  # within the stale timeout (and one check)
    assert "camera: no frame for" in det.health().detail


@pytest.mark.peer
def test_a_receiver_started_mid_stream_waits_for_the_next_keyframe(
    rendered: tuple[Path, dict, list[np.ndarray]],
) -> None:
    folder, cam, _ = rendered
    port = free_udp_port()
    peer = Peer(
        "hal.testing.rtp_camera_peer", "--images", str(folder), "--port", str(port), "--fps", "10", "--gop", "30"
    )
    det = detector(cam, port)
    try:
        time.sleep(0.45)  # the stream is under way: its keyframe went out before anyone listened
        det.connect()
        assert wait_until(lambda: det.stream.depacketizer.counters.packets > 0, 2.0)
        h = det.health()
        assert h.state == HealthState.MISSING and "waiting for a keyframe" in h.detail, h
        assert wait_until(lambda: det.health().state == HealthState.OK, 5.0), det.health()
        c = det.stream.depacketizer.counters
        assert c.frames_dropped >= 10 and det.stream.decoder.errors == 0  # P frames before the IDR: never decoded
    finally:
        peer.stop()
        det.disconnect()


@pytest.mark.peer
def test_lost_and_reordered_packets_cost_frames_never_broken_ones(
    rendered: tuple[Path, dict, list[np.ndarray]],
) -> None:
    folder, cam, _ = rendered
    port = free_udp_port()
    det = detector(cam, port)
    det.connect()
    peer = Peer(
        "hal.testing.rtp_camera_peer",
        "--images",
        str(folder),
        "--port",
        str(port),
        "--fps",
        "10",
        "--loss",
        "0.003",
        "--reorder",
        "0.05",
    )
    try:
        c = det.stream.depacketizer.counters
        # a loss is counted when the depacketizer gives up on the packet, the broken frame
        # is dropped when that frame ends: the second comes a few packets after the first
        assert wait_until(lambda: c.lost >= 1 and c.frames_dropped >= 1, 15.0), det.health()
        assert c.reordered > 0 and c.frames > 0 and c.frames_dropped > 0
        assert det.stream.decoder.errors == 0  # no frame with a hole reaches the decoder
        assert wait_until(lambda: det.worker.detections >= 3, 5.0)
    finally:
        peer.stop()
        det.disconnect()
