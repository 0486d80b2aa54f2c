"""A BlueROV2 camera stream: images encoded as H.264 and sent as RTP over UDP
the way the vehicle's companion computer sends its camera, for tests and dry
runs without the vehicle. Run it as its own process::

    python -m hal.testing.rtp_camera_peer --images DIR --port 5600 --fps 10

It prints ``READY <port>`` once streaming to 127.0.0.1:<port> (only this
computer). Written from what the sending side does, not from the receiver:

* **The pipeline**: BlueOS's camera manager sends the camera's H.264 through
  ``h264parse ! rtph264pay aggregate-mode=zero-latency config-interval=10
  pt=96`` (its V4L2 pipeline); the older companion scripts ``rtph264pay
  config-interval=10 pt=96 ! udpsink port=5600``. Here the images (a folder of
  PNG/JPEG files, looped) are encoded by x264 (PyAV's ``libx264``): constrained
  baseline profile, no B frames, a keyframe every ``--gop`` frames (the camera's
  own interval is not published: an assumption), SPS and PPS repeated before
  each IDR picture and nowhere else. A receiver that starts mid-stream gets
  nothing it can decode until the next IDR.
* **RTP** (RFC 3550): payload type 96, 90 kHz timestamps from the frame times,
  random initial sequence number, timestamp and SSRC (``rtph264pay``'s
  defaults), the marker bit on the last packet of each frame.
* **Payloads** (RFC 6184, packetization mode 1, as ``rtph264pay`` builds them):
  packets of at most ``--mtu`` bytes with the RTP header (``rtph264pay``'s
  default 1400); NAL units that fit are aggregated in a STAP-A until the first
  slice (the ``zero-latency`` mode: an aggregate ends with a VCL unit), a
  single one goes alone, a larger one is cut into FU-A fragments.
* **The network**: ``--loss P`` drops each packet with probability P,
  ``--reorder P`` swaps a packet with the next one with probability P.

stdin, one JSON object per line: ``{"cmd": "stop"}`` (nothing is sent any more:
the camera's pipeline stopped, the process lives on), ``{"cmd": "resume"}``
(sending again, from the next keyframe), ``{"cmd": "loss", "p": 0.05}``,
``{"cmd": "report"}`` (prints ``REPORT {json}``: frames, keyframes, packets
sent and dropped, payload kinds), ``{"cmd": "quit"}``.
"""

from __future__ import annotations

import argparse
import json
import random
import socket
import struct
import sys
import threading
import time
from fractions import Fraction
from pathlib import Path

import av
import cv2
import numpy as np

RTP_CLOCK = 90000
RTP_HEADER = 12
STAP_A, FU_A = 24, 28
IMAGE_SUFFIXES = (".png", ".jpg", ".jpeg", ".bmp")


def split_annexb(data: bytes) -> list[bytes]:
    """The NAL units of an Annex B byte stream (3- or 4-byte start codes)."""
    out: list[bytes] = []
    i, n = 0, len(data)
    starts: list[int] = []
    while i < n - 2:
        if data[i] == 0 and data[i + 1] == 0 and data[i + 2] == 1:
            starts.append(i + 3)
            i += 3
        else:
            i += 1
    for k, s in enumerate(starts):
        end = starts[k + 1] - 3 if k + 1 < len(starts) else n
        nal = data[s:end].rstrip(b"\x00") if k + 1 < len(starts) else data[s:end]
        if nal:
            out.append(nal)
    return out


def payloads(nals: list[bytes], max_payload: int) -> list[tuple[str, bytes]]:
    """RTP payloads (kind, bytes) of one frame's NAL units (see the module docstring)."""
    out: list[tuple[str, bytes]] = []
    agg: list[bytes] = []

    def flush() -> None:
        if len(agg) == 1:
            out.append(("single", agg[0]))
        elif agg:
            f_nri = max(n[0] & 0x60 for n in agg) | (0x80 if any(n[0] & 0x80 for n in agg) else 0)
            out.append(("stap-a", bytes([f_nri | STAP_A]) + b"".join(struct.pack("!H", len(n)) + n for n in agg)))
        agg.clear()

    for nal in nals:
        vcl = 1 <= (nal[0] & 0x1F) <= 5
        if len(nal) > max_payload:
            flush()
            indicator = (nal[0] & 0xE0) | FU_A
            body, step = nal[1:], max_payload - 2
            for pos in range(0, len(body), step):
                start, end = pos == 0, pos + step >= len(body)
                header = (0x80 if start else 0) | (0x40 if end else 0) | (nal[0] & 0x1F)
                out.append(("fu-a", bytes([indicator, header]) + body[pos : pos + step]))
            continue
        if agg and 1 + sum(2 + len(n) for n in agg) + 2 + len(nal) > max_payload:
            flush()
        agg.append(nal)
        if vcl:
            flush()
    flush()
    return out


class Stream:
    """The encoder and the RTP sender's state."""

    def __init__(self, size: tuple[int, int], fps: float, gop: int, mtu: int, pt: int, rng: random.Random) -> None:
        w, h = size
        self.fps, self.gop, self.mtu, self.pt, self.rng = fps, gop, mtu, pt, rng
        self.encoder = self._encoder(w, h)
        self.seq = rng.randrange(1 << 16)
        self.ts0 = rng.randrange(1 << 32)
        self.ssrc = rng.randrange(1 << 32)
        self.loss = 0.0
        self.reorder = 0.0
        self.sending = True
        self.force_key = False
        self.report = {"frames": 0, "keyframes": 0, "packets": 0, "dropped": 0, "single": 0, "stap-a": 0, "fu-a": 0}
        self._held: bytes | None = None
        self.lock = threading.Lock()

    def _encoder(self, w: int, h: int) -> av.VideoCodecContext:
        enc = av.CodecContext.create("libx264", "w")
        enc.width, enc.height = w, h
        enc.pix_fmt = "yuv420p"
        enc.time_base = Fraction(1, RTP_CLOCK)
        enc.framerate = Fraction(self.fps).limit_denominator(1000)
        enc.options = {
            "preset": "ultrafast",
            "tune": "zerolatency",
            "profile": "baseline",
            "x264-params": f"keyint={self.gop}:min-keyint={self.gop}:scenecut=0:bframes=0:repeat-headers=1",
        }
        return enc

    def frame(self, image: np.ndarray, index: int, out: socket.socket, dest: tuple[str, int]) -> None:
        """Encode one BGR image (the ``index``-th frame) and send its packets."""
        vf = av.VideoFrame.from_ndarray(image, format="bgr24")
        vf.pts = int(round(index * RTP_CLOCK / self.fps))
        with self.lock:
            if self.force_key:
                vf.pict_type = av.video.frame.PictureType.I
                self.force_key = False
        for packet in self.encoder.encode(vf):
            nals = split_annexb(bytes(packet))
            ts = (self.ts0 + int(packet.pts or 0)) & 0xFFFFFFFF
            parts = payloads(nals, self.mtu - RTP_HEADER)
            with self.lock:
                if not self.sending:
                    continue
                self.report["frames"] += 1
                self.report["keyframes"] += int(any((n[0] & 0x1F) == 5 for n in nals))
                for k, (kind, body) in enumerate(parts):
                    marker = 0x80 if k == len(parts) - 1 else 0
                    rtp = struct.pack("!BBHII", 0x80, marker | self.pt, self.seq, ts, self.ssrc) + body
                    self.seq = (self.seq + 1) & 0xFFFF
                    self.report[kind] += 1
                    self._send(rtp, out, dest)
        with self.lock:
            if self._held is not None and self.sending:  # a packet held back for reordering goes now
                out.sendto(self._held, dest)
                self._held = None

    def _send(self, rtp: bytes, out: socket.socket, dest: tuple[str, int]) -> None:
        if self.rng.random() < self.loss:
            self.report["dropped"] += 1
            return
        self.report["packets"] += 1
        if self._held is None and self.rng.random() < self.reorder:
            self._held = rtp  # sent after the next one
            return
        out.sendto(rtp, dest)
        if self._held is not None:
            out.sendto(self._held, dest)
            self._held = None

    def command(self, msg: dict) -> str | None:
        cmd = msg.get("cmd")
        with self.lock:
            if cmd == "stop":
                self.sending = False
            elif cmd == "resume":
                self.sending, self.force_key = True, True
            elif cmd == "loss":
                self.loss = float(msg.get("p", 0.0))
            elif cmd == "reorder":
                self.reorder = float(msg.get("p", 0.0))
            elif cmd == "report":
                return "REPORT " + json.dumps(self.report)
        return None


def load_images(path: Path) -> list[np.ndarray]:
    files = sorted(p for p in path.iterdir() if p.suffix.lower() in IMAGE_SUFFIXES) if path.is_dir() else [path]
    images: list[np.ndarray] = []
    for f in files:
        im = cv2.imread(str(f), cv2.IMREAD_COLOR)
        if im is not None:
            images.append(im)
    if not images:
        raise SystemExit(f"no image in {path}")
    h, w = images[0].shape[:2]
    if w % 2 or h % 2:
        raise SystemExit(f"{path}: {w}x{h}: H.264 4:2:0 needs an even width and height")
    return images


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--images", required=True, help="a folder of images (sent in name order, looped) or one image")
    ap.add_argument("--port", type=int, default=5600, help="UDP port on 127.0.0.1 to send to")
    ap.add_argument("--fps", type=float, default=10.0)
    ap.add_argument("--gop", type=int, default=10, help="frames from one keyframe to the next")
    ap.add_argument("--mtu", type=int, default=1400, help="largest RTP packet, bytes (rtph264pay's default)")
    ap.add_argument("--payload-type", type=int, default=96)
    ap.add_argument("--loss", type=float, default=0.0)
    ap.add_argument("--reorder", type=float, default=0.0)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--max-runtime", type=float, default=300.0)
    args = ap.parse_args(argv)
    images = load_images(Path(args.images))
    h, w = images[0].shape[:2]
    stream = Stream((w, h), args.fps, args.gop, args.mtu, args.payload_type, random.Random(args.seed))
    stream.loss, stream.reorder = args.loss, args.reorder
    quit_flag = threading.Event()

    def commands() -> None:
        for line in sys.stdin:
            try:
                msg = json.loads(line)
            except json.JSONDecodeError:
                continue
            if msg.get("cmd") == "quit":
                break
            out = stream.command(msg)
            if out:
                print(out, flush=True)
        quit_flag.set()

    threading.Thread(target=commands, daemon=True).start()
    sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    dest = ("127.0.0.1", args.port)
    print(f"READY {args.port}", flush=True)
    t0 = time.monotonic()
    index = 0
    while not quit_flag.is_set() and time.monotonic() - t0 < args.max_runtime:
        stream.frame(images[index % len(images)], index, sock, dest)
        index += 1
        quit_flag.wait(max(0.0, t0 + index / args.fps - time.monotonic()))
    sock.close()
    return 0


if __name__ == "__main__":
    sys.exit(main())
