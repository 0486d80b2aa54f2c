"""H.264 video carried in RTP over UDP, as the BlueROV2's companion sends it
(GStreamer ``rtph264pay ! udpsink``, payload type 96, port 5600): the packets
(RFC 3550) put back in order and depacketized (RFC 6184) into access units,
one per frame, in Annex B form (start codes) for a decoder.

No I/O here: :class:`H264Depacketizer` takes datagrams and returns access
units. What it handles:

* **RTP** (RFC 3550 section 5.1): version 2, padding (the last byte says how
  many to drop), CSRC list, header extension; another payload type or SSRC
  than the stream's is counted and dropped (a new SSRC, a sender restarted,
  starts the stream anew).
* **Order**: packets are taken in sequence-number order (modulo 2^16). One that
  comes early waits, at most ``reorder_s`` and ``reorder_packets`` of them; then
  the missing ones count as lost. A packet older than the one expected (late,
  or a duplicate) is dropped.
* **Payloads** of packetization mode 1 (non-interleaved, the only one
  ``rtph264pay`` sends): a single NAL unit (types 1-23), STAP-A (24: 16-bit
  size + NAL unit, repeated) and FU-A (28: a NAL unit in fragments, start and
  end bits, the NAL header rebuilt from the FU indicator's F and NRI and the
  FU header's type). STAP-B, MTAP and FU-B belong to the interleaved mode and
  are counted as unsupported.
* **Frames**: an access unit is the NAL units of one RTP timestamp; it ends
  with the marker bit (or when the next timestamp begins).
* **Starting and losses**: the sender puts SPS and PPS in-band before each IDR
  picture and nowhere else, so a receiver starting mid-stream has nothing to
  decode until the next IDR. After a lost packet the frame it belonged to is
  dropped and so is every frame until the next IDR (P frames refer to the
  lost data: decoding them gives smeared images the pipe detector would
  measure). Frames are passed on only once SPS and PPS have been seen.
"""

from __future__ import annotations

import struct
from dataclasses import dataclass, field

#: NAL unit types (ITU-T H.264 Table 7-1) and RTP payload structures (RFC 6184 Table 1).
NAL_SLICE, NAL_IDR, NAL_SEI, NAL_SPS, NAL_PPS, NAL_AUD = 1, 5, 6, 7, 8, 9
STAP_A, STAP_B, MTAP16, MTAP24, FU_A, FU_B = 24, 25, 26, 27, 28, 29
START_CODE = b"\x00\x00\x00\x01"
RTP_HEADER = struct.Struct("!BBHII")


class RtpError(ValueError):
    """A datagram that is not a usable RTP packet (the message says why)."""


@dataclass(frozen=True)
class RtpPacket:
    """One RTP packet's header fields and payload (RFC 3550 section 5.1)."""

    marker: bool
    payload_type: int
    seq: int
    timestamp: int
    ssrc: int
    payload: bytes


def parse_rtp(data: bytes) -> RtpPacket:
    """The RTP packet in ``data``; :class:`RtpError` for anything else."""
    if len(data) < RTP_HEADER.size:
        raise RtpError(f"{len(data)} bytes, shorter than an RTP header")
    b0, b1, seq, ts, ssrc = RTP_HEADER.unpack_from(data)
    if b0 >> 6 != 2:
        raise RtpError(f"RTP version {b0 >> 6}, not 2")
    pos = RTP_HEADER.size + 4 * (b0 & 0x0F)  # the CSRC list
    if b0 & 0x10:  # header extension: 16-bit profile word, 16-bit length in 32-bit words
        if len(data) < pos + 4:
            raise RtpError("header extension cut short")
        pos += 4 + 4 * struct.unpack_from("!H", data, pos + 2)[0]
    end = len(data)
    if b0 & 0x20:  # padding: its length is the last byte
        end -= data[-1]
    if end < pos:
        raise RtpError("header, extension and padding longer than the packet")
    return RtpPacket(bool(b1 & 0x80), b1 & 0x7F, seq, ts, ssrc, bytes(data[pos:end]))


@dataclass
class AccessUnit:
    """The NAL units of one frame; ``arrived``: the receiving clock's time (s) of
    its first packet; ``timestamp``: its RTP timestamp (90 kHz)."""

    timestamp: int
    arrived: float
    nals: list[bytes] = field(default_factory=list)

    @property
    def types(self) -> set[int]:
        return {n[0] & 0x1F for n in self.nals if n}

    @property
    def has_idr(self) -> bool:
        return NAL_IDR in self.types

    def annexb(self) -> bytes:
        """The NAL units with start codes, as a decoder reads a byte stream."""
        return b"".join(START_CODE + n for n in self.nals)


@dataclass
class RtpCounters:
    """What the depacketizer has seen since the start (``maris hal check`` shows them)."""

    packets: int = 0
    lost: int = 0
    #: Packets that arrived ahead of a missing one (it came later, or was lost).
    reordered: int = 0
    late: int = 0
    bad: int = 0
    foreign: int = 0
    unsupported: int = 0
    frames: int = 0
    frames_dropped: int = 0


def _seq_after(a: int, b: int) -> bool:
    """True when sequence number ``a`` comes after ``b`` (modulo 2^16)."""
    return 0 < ((a - b) & 0xFFFF) < 0x8000


class H264Depacketizer:
    """Datagrams in, complete access units out (see the module docstring)."""

    def __init__(self, payload_type: int = 96, reorder_packets: int = 32, reorder_s: float = 0.05) -> None:
        self.payload_type = payload_type
        self.reorder_packets = reorder_packets
        self.reorder_s = reorder_s
        self.counters = RtpCounters()
        self.ssrc: int | None = None
        self._expected: int | None = None
        self._waiting: dict[int, tuple[RtpPacket, float]] = {}
        self._au: AccessUnit | None = None
        self._au_broken = False
        self._fu: bytearray | None = None
        self._need_idr = True
        self._seen_sps = self._seen_pps = False

    @property
    def waiting_for_idr(self) -> bool:
        """True until the next IDR frame (at the start, after a loss)."""
        return self._need_idr

    def push(self, data: bytes, arrived: float) -> list[AccessUnit]:
        """One datagram received at ``arrived`` (s); the access units it completes."""
        c = self.counters
        try:
            pkt = parse_rtp(data)
        except RtpError:
            c.bad += 1
            return []
        if pkt.payload_type != self.payload_type:
            c.foreign += 1
            return []
        c.packets += 1
        if pkt.ssrc != self.ssrc:  # the first packet, or the sender restarted: a new stream
            self.ssrc, self._expected = pkt.ssrc, pkt.seq
            self._waiting.clear()
            self._drop_frame()
            self._need_idr = True
        assert self._expected is not None
        if pkt.seq != self._expected and not _seq_after(pkt.seq, self._expected):
            c.late += 1  # older than the one expected: a late or duplicated packet
            return []
        if pkt.seq != self._expected:
            if pkt.seq in self._waiting:
                c.late += 1
                return []
            self._waiting[pkt.seq] = (pkt, arrived)
            return self.expire(arrived)
        out = self._take(pkt, arrived)
        return out + self._drain()

    def expire(self, now: float) -> list[AccessUnit]:
        """Give up on missing packets that early ones have waited for too long or too many
        of (call it also when nothing arrives); the access units that completes."""
        out: list[AccessUnit] = []
        while self._waiting and self._expected is not None:
            oldest = min(t for _p, t in self._waiting.values())
            if len(self._waiting) <= self.reorder_packets and now - oldest <= self.reorder_s:
                break
            nearest = min(self._waiting, key=lambda s: (s - self._expected) & 0xFFFF)  # type: ignore[operator]
            self.counters.lost += (nearest - self._expected) & 0xFFFF
            self._lose()
            self._expected = nearest
            out += self._drain()
        return out

    def _drain(self) -> list[AccessUnit]:
        """Packets that waited for the one just taken, in order."""
        out: list[AccessUnit] = []
        while self._expected in self._waiting:
            pkt, arrived = self._waiting.pop(self._expected)
            self.counters.reordered += 1
            out += self._take(pkt, arrived)
        return out

    def _lose(self) -> None:
        """Packets are missing: the frame being built is broken, and so is every frame to the next IDR."""
        self._au_broken = True
        self._fu = None
        self._need_idr = True

    def _drop_frame(self) -> None:
        if self._au is not None:
            self.counters.frames_dropped += 1
        self._au, self._au_broken, self._fu = None, False, None

    def _take(self, pkt: RtpPacket, arrived: float) -> list[AccessUnit]:
        """The next packet in sequence."""
        self._expected = (pkt.seq + 1) & 0xFFFF
        out: list[AccessUnit] = []
        if self._au is not None and pkt.timestamp != self._au.timestamp:  # its marker was lost
            done = self._finish()
            out += [done] if done is not None else []
        if self._au is None:
            self._au = AccessUnit(pkt.timestamp, arrived)
        self._payload(pkt.payload)
        if pkt.marker:
            done = self._finish()
            out += [done] if done is not None else []
        return out

    def _payload(self, p: bytes) -> None:
        assert self._au is not None
        if not p:
            self.counters.bad += 1
            return
        kind = p[0] & 0x1F
        if 1 <= kind <= 23:
            self._au.nals.append(p)
        elif kind == STAP_A:
            pos = 1
            while pos + 2 <= len(p):
                (size,) = struct.unpack_from("!H", p, pos)
                pos += 2
                if size == 0 or pos + size > len(p):
                    self.counters.bad += 1
                    self._au_broken = True
                    return
                self._au.nals.append(p[pos : pos + size])
                pos += size
        elif kind == FU_A:
            if len(p) < 2:
                self.counters.bad += 1
                self._au_broken = True
                return
            start, end = bool(p[1] & 0x80), bool(p[1] & 0x40)
            if start:
                self._fu = bytearray([(p[0] & 0xE0) | (p[1] & 0x1F)]) + p[2:]
            elif self._fu is None:  # a fragment whose start was lost
                self._au_broken = True
                return
            else:
                self._fu += p[2:]
            if end and self._fu is not None:
                self._au.nals.append(bytes(self._fu))
                self._fu = None
        else:
            self.counters.unsupported += 1
            self._au_broken = True

    def _finish(self) -> AccessUnit | None:
        """The frame built so far, if it is whole and decodable from what came before."""
        au, broken = self._au, self._au_broken or self._fu is not None
        self._au, self._au_broken, self._fu = None, False, None
        if au is None or not (au.nals or broken):
            return None
        types = au.types
        self._seen_sps |= NAL_SPS in types
        self._seen_pps |= NAL_PPS in types
        if broken:
            self._need_idr = True
        elif NAL_IDR in types and self._seen_sps and self._seen_pps:
            self._need_idr = False
        if broken or self._need_idr:
            self.counters.frames_dropped += 1
            return None
        self.counters.frames += 1
        return au
