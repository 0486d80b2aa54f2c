"""A Blue Robotics Ping echosounder (Ping1D) speaking the ping protocol, for tests
and dry runs without the sonar. Run it as its own process::

    python -m hal.testing.ping_peer --transport serial          # a new pseudo-terminal
    python -m hal.testing.ping_peer --transport udp --port 0    # UDP on 127.0.0.1

It prints ``READY <pty path>`` or ``READY <udp port>``. Written from
``bluerobotics/ping-protocol`` (``src/definitions/common.json``,
``ping1d.json``) with its own codec: a frame is ``B`` ``R``, payload length
(u16), message id (u16), source and destination device ids (u8 each), the
payload, and a u16 checksum, the sum of every byte before it; little-endian.

* **Nothing unasked**: the sonar answers ``general_request`` (id 6, the
  requested id) and the older form, an empty message carrying the id it asks
  for (brping's ``legacyRequest``), with that message; a get id it does not
  have gets a ``nack`` (2). Set messages are answered with ``ack`` (1) and
  applied (speed of sound, range, ping interval, gain, auto mode, ping enable).
  ``continuous_start`` (1400) starts a stream of ``profile`` (1300) messages,
  one per ping, until ``continuous_stop`` (1401); any other id is refused with
  a ``nack`` (the definitions document only 1300).
* **Measurements**: one ping every ``ping_interval`` ms while pinging is
  enabled, each advancing ``ping_number``; ``distance`` answers carry the
  latest ping's distance and confidence (the altitude set on stdin, with a
  millimetre of noise). With pinging disabled the number stops.
* **Serial**: bytes before a ``B`` ``R`` start are skipped (brping sends a
  break and a ``U`` for the sonar's baud-rate detection first).

stdin, one JSON object per line: ``{"cmd": "altitude", "m": 2.5, "confidence":
95}``, ``{"cmd": "stall"}`` / ``{"cmd": "resume"}`` (no answers at all),
``{"cmd": "corrupt", "count": 2}`` (next answers with a wrong checksum),
``{"cmd": "report"}`` (``REPORT {json}``), ``{"cmd": "quit"}``.

``--follow-mavlink URL --floor-depth D`` puts the sonar on a vehicle that speaks
MAVLink (an ArduSub SITL's spare port, e.g. ``tcp:127.0.0.1:5762``): it asks for
GLOBAL_POSITION_INT at 10 Hz and measures ``D`` less the vehicle's depth (its
``relative_alt`` below the surface), the flat floor of a pool ``D`` m deep under
a level vehicle.
"""

from __future__ import annotations

import argparse
import json
import os
import pty
import random
import select
import socket
import struct
import sys
import threading
import time
import tty
from typing import Any

DEVICE_ID = 1
ACK, NACK, GENERAL_REQUEST = 1, 2, 6
DEVICE_INFORMATION, PROTOCOL_VERSION = 4, 5
GENERAL_INFO, DISTANCE_SIMPLE, DISTANCE = 1210, 1211, 1212
SPEED_OF_SOUND, RANGE, MODE_AUTO, PING_INTERVAL, GAIN, PING_ENABLE = 1203, 1204, 1205, 1206, 1207, 1215
PROFILE, CONTINUOUS_START, CONTINUOUS_STOP = 1300, 1400, 1401
SET_RANGE, SET_SPEED_OF_SOUND, SET_MODE_AUTO, SET_PING_INTERVAL, SET_GAIN, SET_PING_ENABLE = (
    1001,
    1002,
    1003,
    1004,
    1005,
    1006,
)


def checksum(data: bytes) -> int:
    return sum(data) & 0xFFFF


def message(msg_id: int, payload: bytes, dst: int) -> bytes:
    head = b"BR" + struct.pack("<HHBB", len(payload), msg_id, DEVICE_ID, dst)
    body = head + payload
    return body + struct.pack("<H", checksum(body))


class Sonar:
    """The sonar's settings and measurements."""

    def __init__(self) -> None:
        self.lock = threading.Lock()
        self.altitude_m = 3.0
        self.confidence = 100
        self.speed_of_sound = 1500000  # mm/s
        self.scan = (0, 10000)  # mm
        self.interval_ms = 100
        self.gain = 2
        self.auto = 1
        self.enabled = 1
        self.ping_number = 0
        self.distance_mm = 0
        self.next_ping = 0.0
        self.streaming = False
        self.stalled = False
        self.corrupt = 0
        self.requests: dict[str, int] = {}
        self.rejected = 0

    def step(self, now: float) -> list[tuple[int, bytes]]:
        """Pings that are due; the profile messages they stream."""
        out: list[tuple[int, bytes]] = []
        if self.enabled and now >= self.next_ping:
            self.next_ping = max(self.next_ping + self.interval_ms / 1000.0, now)
            self.ping_number += 1
            # the sonar times the echo: its distance scales with the speed of sound it is set to (water: 1500 m/s)
            true_mm = self.altitude_m * 1000 * self.speed_of_sound / 1500000
            self.distance_mm = max(0, int(round(true_mm + random.gauss(0.0, 1.0))))
            profile = self.payload(PROFILE)
            if self.streaming and profile is not None:
                out.append((PROFILE, profile))
        return out

    def payload(self, msg_id: int) -> bytes | None:
        d, c = self.distance_mm, self.confidence
        if msg_id == PROTOCOL_VERSION:
            return bytes((1, 0, 0, 0))
        if msg_id == DEVICE_INFORMATION:
            return bytes((1, 1, 3, 29, 0, 0))
        if msg_id == GENERAL_INFO:
            return struct.pack("<HHHHBB", 3, 29, 5000, self.interval_ms, self.gain, self.auto)
        if msg_id == DISTANCE_SIMPLE:
            return struct.pack("<IB", d, c)
        if msg_id == DISTANCE:
            return struct.pack("<IHHIIII", d, c, 100, self.ping_number, *self.scan, self.gain)
        if msg_id == SPEED_OF_SOUND:
            return struct.pack("<I", self.speed_of_sound)
        if msg_id == RANGE:
            return struct.pack("<II", *self.scan)
        if msg_id == MODE_AUTO:
            return bytes((self.auto,))
        if msg_id == PING_INTERVAL:
            return struct.pack("<H", self.interval_ms)
        if msg_id == GAIN:
            return struct.pack("<I", self.gain)
        if msg_id == PING_ENABLE:
            return bytes((self.enabled,))
        if msg_id == PROFILE:
            points = bytes(200)
            return struct.pack("<IHHIIIIH", d, c, 100, self.ping_number, *self.scan, self.gain, len(points)) + points
        return None

    def handle(self, msg_id: int, payload: bytes, src: int) -> list[bytes]:
        """Answers to one received message."""
        self.requests[str(msg_id)] = self.requests.get(str(msg_id), 0) + 1
        if msg_id == GENERAL_REQUEST and len(payload) == 2:
            (wanted,) = struct.unpack("<H", payload)
            return [self._answer(wanted, src)]
        if msg_id == CONTINUOUS_START and len(payload) == 2:
            (what,) = struct.unpack("<H", payload)
            if what != PROFILE:
                return [self._nack(msg_id, src, f"cannot stream {what}")]
            self.streaming = True
            return [message(ACK, struct.pack("<H", msg_id), src)]
        if msg_id == CONTINUOUS_STOP:
            self.streaming = False
            return [message(ACK, struct.pack("<H", msg_id), src)]
        setters = {
            SET_SPEED_OF_SOUND: ("<I", "speed_of_sound"),
            SET_PING_INTERVAL: ("<H", "interval_ms"),
            SET_GAIN: ("<B", "gain"),
            SET_MODE_AUTO: ("<B", "auto"),
            SET_PING_ENABLE: ("<B", "enabled"),
        }
        if msg_id in setters:
            fmt, attr = setters[msg_id]
            if len(payload) != struct.calcsize(fmt):
                return [self._nack(msg_id, src, "wrong payload length")]
            setattr(self, attr, struct.unpack(fmt, payload)[0])
            return [message(ACK, struct.pack("<H", msg_id), src)]
        if msg_id == SET_RANGE and len(payload) == 8:
            start, length = struct.unpack("<II", payload)
            if length < 1000:
                return [self._nack(msg_id, src, "scan length below 1000 mm")]
            self.scan = (start, length)
            return [message(ACK, struct.pack("<H", msg_id), src)]
        if not payload:  # an empty message asks for that message (the legacy request)
            return [self._answer(msg_id, src)]
        return [self._nack(msg_id, src, "unknown message")]

    def _answer(self, wanted: int, src: int) -> bytes:
        payload = self.payload(wanted)
        if payload is None:
            return self._nack(wanted, src, "no such message")
        return message(wanted, payload, src)

    def _nack(self, msg_id: int, src: int, text: str) -> bytes:
        self.rejected += 1
        return message(NACK, struct.pack("<H", msg_id) + text.encode(), src)

    def command(self, msg: dict[str, Any]) -> str | None:
        cmd = msg.get("cmd")
        if cmd == "altitude":
            self.altitude_m = float(msg["m"])
            self.confidence = int(msg.get("confidence", self.confidence))
        elif cmd in ("stall", "resume"):
            self.stalled = cmd == "stall"
        elif cmd == "corrupt":
            self.corrupt += int(msg.get("count", 1))
        elif cmd == "report":
            return "REPORT " + json.dumps(
                {
                    "ping_number": self.ping_number,
                    "requests": self.requests,
                    "streaming": self.streaming,
                    "speed_of_sound": self.speed_of_sound,
                    "rejected": self.rejected,
                }
            )
        return None


class Parser:
    """Incremental frame parser: yields (msg_id, payload, src) of frames whose checksum holds."""

    def __init__(self) -> None:
        self.buf = bytearray()

    def feed(self, data: bytes) -> list[tuple[int, bytes, int]]:
        self.buf += data
        out: list[tuple[int, bytes, int]] = []
        while True:
            start = self.buf.find(b"BR")
            if start < 0:
                del self.buf[:-1]
                return out
            del self.buf[:start]
            if len(self.buf) < 8:
                return out
            length, msg_id, src, _dst = struct.unpack("<HHBB", self.buf[2:8])
            if length > 2048:
                del self.buf[:2]
                continue
            end = 8 + length + 2
            if len(self.buf) < end:
                return out
            frame = bytes(self.buf[:end])
            del self.buf[:end]
            if struct.unpack("<H", frame[-2:])[0] == checksum(frame[:-2]):
                out.append((msg_id, frame[8:-2], src))


def follow_depth(sonar: Sonar, url: str, floor_depth: float, quit_flag: threading.Event) -> None:
    """Keep ``sonar.altitude_m`` at ``floor_depth`` less the MAVLink vehicle's depth."""
    from pymavlink import mavutil  # only with --follow-mavlink: pymavlink is heavy to load

    link = None
    while link is None and not quit_flag.is_set():
        try:
            link = mavutil.mavlink_connection(url, source_system=254)
        except OSError:  # the autopilot not up yet
            quit_flag.wait(1.0)
    if link is None:
        return
    asked = 0.0
    while not quit_flag.is_set():
        now = time.monotonic()
        if now - asked > 2.0:  # ArduSub streams nothing unasked (again after a reboot)
            link.mav.command_long_send(1, 0, 511, 0, 33, 100000, 0, 0, 0, 0, 0)  # SET_MESSAGE_INTERVAL, 10 Hz
            asked = now
        msg = link.recv_match(type="GLOBAL_POSITION_INT", blocking=True, timeout=0.5)
        if msg is not None:
            depth = max(0.0, -msg.relative_alt / 1000.0)
            with sonar.lock:
                sonar.altitude_m = max(0.0, floor_depth - depth)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--transport", choices=["serial", "udp"], default="serial")
    ap.add_argument("--port", type=int, default=0)
    ap.add_argument("--altitude", type=float, default=3.0)
    ap.add_argument("--max-runtime", type=float, default=300.0)
    ap.add_argument("--follow-mavlink", default=None, metavar="URL", help="the vehicle whose depth sets the altitude")
    ap.add_argument("--floor-depth", type=float, default=3.0, metavar="M", help="depth of the floor, m")
    args = ap.parse_args(argv)
    sonar = Sonar()
    sonar.altitude_m = args.altitude
    quit_flag = threading.Event()
    if args.follow_mavlink:
        threading.Thread(
            target=follow_depth, args=(sonar, args.follow_mavlink, args.floor_depth, quit_flag), daemon=True
        ).start()

    def commands() -> None:
        for line in sys.stdin:
            try:
                msg = json.loads(line)
            except json.JSONDecodeError:
                continue
            if msg.get("cmd") == "quit":
                break
            with sonar.lock:
                out = sonar.command(msg)
            if out:
                print(out, flush=True)
        quit_flag.set()

    threading.Thread(target=commands, daemon=True).start()
    sock = None
    if args.transport == "udp":
        sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        sock.bind(("127.0.0.1", args.port))
        print(f"READY {sock.getsockname()[1]}", flush=True)
        fd = sock.fileno()
    else:
        master, slave = pty.openpty()
        tty.setraw(slave)
        os.set_blocking(master, False)
        print(f"READY {os.ttyname(slave)}", flush=True)
        fd = master
    parser = Parser()
    host: tuple[str, int] | None = None
    t0 = time.monotonic()
    try:
        while not quit_flag.is_set() and time.monotonic() - t0 < args.max_runtime:
            r, _, _ = select.select([fd], [], [], 0.005)
            out: list[bytes] = []
            with sonar.lock:
                if r:
                    try:
                        if sock is not None:
                            data, host = sock.recvfrom(65536)
                        else:
                            data = os.read(master, 4096)
                    except (BlockingIOError, OSError):
                        data = b""
                    if not sonar.stalled:
                        for msg_id, payload, src in parser.feed(data):
                            out += sonar.handle(msg_id, payload, src)
                out += [message(mid, p, 0) for mid, p in sonar.step(time.monotonic())]
                if sonar.stalled:
                    out = []
                for i, m in enumerate(out):
                    if sonar.corrupt:
                        sonar.corrupt -= 1
                        out[i] = m[:-2] + bytes(((m[-2] + 1) & 0xFF, m[-1]))
            for m in out:
                try:
                    if sock is not None:
                        if host is not None:
                            sock.sendto(m, host)
                    else:
                        os.write(master, m)
                except OSError:
                    pass
    finally:
        if sock is not None:
            sock.close()
        else:
            os.close(master)
            os.close(slave)
    return 0


if __name__ == "__main__":
    sys.exit(main())
