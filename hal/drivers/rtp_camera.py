"""The BlueROV2's camera stream: H.264 in RTP over UDP, received and decoded
on its own thread.

BlueOS's camera manager (and the older companion scripts) send the camera's
own H.264 through GStreamer's ``rtph264pay`` (payload type 96) to UDP port
5600 of the topside computer. This receiver binds that port, puts the packets
in order and back into frames (:mod:`hal.drivers.rtp_h264`, RFC 6184) and
decodes them with FFmpeg's H.264 decoder through PyAV (``av``, a pip wheel
that carries its own FFmpeg: no system GStreamer, which a pip-installed OpenCV
does not have either). The RTP depacketizing is ours rather than FFmpeg's rtp
demuxer: that needs an SDP file describing the stream, and it hands broken
frames to the decoder after a loss, where this one waits for the next IDR
(a smeared frame is a wrong measurement for the pipe detector).

Every frame is stamped with the backend clock at the arrival of its first
packet. :meth:`RtpH264Camera.latest` returns the newest decoded frame.
Health: MISSING until the first frame (with what is missing: no packet at all,
or packets but no keyframe yet); FAULT when the newest frame is older than
``stale_timeout_s`` (the stream stopped: the camera, its pipeline or the
tether); OK otherwise, with the packet counters (lost, reordered, late) and
the frame rate as diagnostics.
"""

from __future__ import annotations

import logging
import socket
import threading
from collections import deque
from collections.abc import Callable
from dataclasses import asdict
from typing import Any

import av
import numpy as np

from hal.drivers.camera import Frame
from hal.drivers.realtime import STEP_GATE, rate_of
from hal.drivers.rtp_h264 import AccessUnit, H264Depacketizer
from hal.interfaces import Health, HealthState

log = logging.getLogger(__name__)

#: BlueOS's default video port on the topside computer.
DEFAULT_PORT = 5600
#: Receive buffer asked of the kernel: a 1080p keyframe is a few hundred kB of packets.
RECV_BUFFER = 4 * 1024 * 1024


class H264Decoder:
    """FFmpeg's H.264 decoder (PyAV): one access unit in, BGR images out."""

    def __init__(self) -> None:
        self._codec: Any = av.CodecContext.create("h264", "r")
        self.errors = 0

    def decode(self, au: AccessUnit) -> list[np.ndarray]:
        try:
            frames = self._codec.decode(av.Packet(au.annexb()))
        except av.error.FFmpegError as exc:  # a frame FFmpeg cannot decode: counted, skipped
            self.errors += 1
            log.debug("H.264 decode error: %s", exc)
            return []
        return [f.to_ndarray(format="bgr24") for f in frames]


class RtpH264Camera:
    """Receiver and decoder of one RTP H.264 stream. ``params``: ``port`` (5600),
    ``bind`` (address to listen on, default all of this computer's), ``payload_type``
    (96), ``stale_timeout_s``; ``clock``: the backend clock (s)."""

    def __init__(self, params: dict[str, Any], clock: Callable[[], float]) -> None:
        self.port = int(params.get("port", DEFAULT_PORT))
        self.bind = str(params.get("bind", "0.0.0.0"))
        self.stale_timeout = float(params.get("stale_timeout_s", 1.0))
        self.depacketizer = H264Depacketizer(int(params.get("payload_type", 96)))
        self.decoder = H264Decoder()
        self._clock = clock
        self._lock = threading.Lock()
        self._latest: Frame | None = None
        self._seq = 0
        self._frame_times: deque[float] = deque(maxlen=60)
        self._last_packet_t: float | None = None
        self._sock: socket.socket | None = None
        self._thread: threading.Thread | None = None
        self._stop = threading.Event()
        self.size: tuple[int, int] | None = None

    @property
    def where(self) -> str:
        return f"udp {self.bind}:{self.port}"

    def connect(self) -> None:
        """Bind the port (OSError if another program holds it) and start receiving."""
        sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        try:
            sock.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, RECV_BUFFER)
            sock.bind((self.bind, self.port))
        except OSError:
            sock.close()
            raise
        sock.settimeout(0.1)
        self._sock = sock
        self._stop.clear()
        self._thread = threading.Thread(target=self._run, name="rtp-camera", daemon=True)
        self._thread.start()

    def disconnect(self) -> None:
        self._stop.set()
        if self._thread is not None:
            self._thread.join(timeout=2.0)
            self._thread = None
        if self._sock is not None:
            self._sock.close()
            self._sock = None

    def _run(self) -> None:
        sock = self._sock
        assert sock is not None
        while not self._stop.is_set():
            try:
                data = sock.recv(65536)
            except TimeoutError:
                self._frames(self.depacketizer.expire(self._clock()))
                continue
            except OSError as exc:
                log.warning("camera stream %s: %s", self.where, exc)
                self._stop.wait(0.1)
                continue
            now = self._clock()
            self._last_packet_t = now
            units = self.depacketizer.push(data, now)
            if units:
                STEP_GATE.wait()  # decode after the control loop's step, not during it
                self._frames(units)

    def _frames(self, units: list[AccessUnit]) -> None:
        for au in units:
            for image in self.decoder.decode(au):
                with self._lock:
                    self._seq += 1
                    self._latest = Frame(au.arrived, image, self._seq)
                    self._frame_times.append(au.arrived)
                    self.size = (image.shape[1], image.shape[0])

    def latest(self) -> Frame | None:
        """The newest decoded frame (None before the first)."""
        with self._lock:
            return self._latest

    def health(self, now: float | None = None) -> Health:
        now = self._clock() if now is None else now
        with self._lock:
            latest, times = self._latest, [t for t in self._frame_times if t > now - 2.0]
        counters = asdict(self.depacketizer.counters)
        info: dict[str, Any] = {
            "where": self.where,
            "fps": rate_of(times),
            "resolution": None if self.size is None else f"{self.size[0]}x{self.size[1]}",
            "frame_age_s": None if latest is None else round(now - latest.t, 3),
            "decode_errors": self.decoder.errors,
            **{k: counters[k] for k in ("packets", "lost", "reordered", "late", "frames_dropped")},
        }
        if latest is None:
            if self._last_packet_t is None:
                why = f"no RTP packet received on {self.where}"
            elif self.depacketizer.waiting_for_idr:
                why = "packets arrive, waiting for a keyframe (SPS, PPS and an IDR picture)"
            else:
                why = "packets arrive, no frame decoded yet"
            return Health(HealthState.MISSING, now, f"camera: {why}", info)
        if now - latest.t > self.stale_timeout:
            return Health(
                HealthState.FAULT,
                now,
                f"camera: no frame for {now - latest.t:.2f} s (limit {self.stale_timeout:.2f} s; stream stopped?)",
                info,
            )
        return Health(HealthState.OK, now, "", info)
