"""A Reach System arm (Alpha 5 or Bravo 7) speaking the Reach serial protocol,
for tests and dry runs without the arm. Run it as its own process::

    python -m hal.testing.reach_peer --transport serial --arm alpha5   # a new pseudo-terminal
    python -m hal.testing.reach_peer --transport udp --port 0 --arm bravo7   # UDP on 127.0.0.1

It prints ``READY <pty path>`` or ``READY <udp port>`` once serving. Its codec is
its own (a bitwise CRC-8 from the documented parameters and the ``cobs``
package), not the driver's. It behaves like the arm as the public sources
describe it, not as the driver expects:

* **Silent until asked** (Reach SDK ``rs_protocol``: ``request()``,
  ``telemetry_heartbeat.py``): a device sends a packet only in answer to a
  REQUEST (one packet per requested id, from each addressed device; 0xFF
  addresses all), or as its heartbeat once HEARTBEAT_SET (the packet ids, up
  to 10) and HEARTBEAT_FREQUENCY (Hz, 1-255) were written to it. Heartbeats
  "can not be stopped and restarted" (the SDK example's note): a frequency of 0
  stops a running heartbeat and a later non-zero frequency does not restart it
  until the device is powered again (this process restarted). Over UDP every
  answer goes to the address of the last datagram received; before any, nothing
  is sent.
* **Modes** (``rs_protocol`` mode.py): devices power up in STANDBY. A MODE
  packet with a known mode byte sets it (an unknown byte is ignored). A demand
  packet (VELOCITY, POSITION, CURRENT) puts a device into that demand's mode,
  as the SDK's examples rely on (they send demands without setting a mode
  first, and ``alpha_hardware`` leaves the mode switching to the arm), except
  in DISABLED, which ignores demands until a MODE packet changes it
  (``alpha_hardware`` disables the arm on deactivation, and activates it by
  setting STANDBY). STANDBY, DISABLED, ZERO_VELOCITY and POSITION_HOLD stop the
  device.
* **No timeout on a velocity demand** (the protocol documents none): a device in
  VELOCITY mode keeps its last demand for ever, until its own position limit
  stops it. ``--velocity-timeout S`` models a firmware that drops a demand older
  than S seconds instead (the SDK's ``basic_actuator_control.py`` resends its
  velocity "every 50 ms to prevent timeout", without saying what the timeout is).
* **Limits**: demands are clipped to the device's velocity (and current)
  limits; a joint stops at its position limits (the device's soft limits,
  readable as POSITION_LIMITS / VELOCITY_LIMITS / CURRENT_LIMITS, two floats:
  maximum then minimum, ``bplprotocol`` packetID.py). Limit packets sent to
  the device are ignored here (their saving needs the SDK's configuration
  mode). Velocities follow demands with a bounded acceleration.
* **Units** (``bplprotocol`` packetID.py): rad, rad/s; the jaw (device 0x01) in
  mm and mm/s; currents in mA. The jaw closes towards 0 mm; an object of
  ``width_mm`` between the fingers stops it and its current rises to the
  demanded current (CURRENT mode) or a stall current (VELOCITY mode).
* **Serial bandwidth**: the pty path sends at most baudrate/10 bytes per
  second (8N1); frames that do not fit within 50 ms of line time are dropped
  and counted (``tx_dropped``), as a UART's transmit buffer would lose them.

Fault injection, one JSON object per line on stdin:
``{"cmd": "stall"}`` (firmware hung: nothing is received or sent any more, the
joints go on as they were), ``{"cmd": "resume"}``, ``{"cmd": "corrupt", "kind":
"crc"|"cobs", "count": 3}`` (the next frames sent are corrupted that way),
``{"cmd": "joint_fault", "device": 3, "flags": 4}`` (hardware status flags set,
the device stops and reads DISABLED), ``{"cmd": "clear_fault", "device": 3}``,
``{"cmd": "object", "width_mm": 8.0}`` (``null`` removes it), ``{"cmd":
"report"}`` (prints ``REPORT {json}``), ``{"cmd": "quit"}``. A killed process
closes the pty master: to the driver the serial port breaks.
"""

from __future__ import annotations

import argparse
import json
import os
import pty
import select
import socket
import struct
import sys
import threading
import time
import tty
from dataclasses import dataclass, field
from typing import Any

from cobs import cobs

STEP = 0.002  # s, physics and heartbeat step
ACCEL = 4.0  # rad/s^2 (mm/s^2 x 10 for the jaw) with which velocities follow their demands
STALL_CURRENT_MA = 600.0  # mA drawn by a jaw pushing on an object in velocity mode

# packet ids and modes (Reach SDK rs_protocol packetID.py / mode.py)
MODE, VELOCITY, POSITION, CURRENT = 0x01, 0x02, 0x03, 0x05
POSITION_LIMITS, VELOCITY_LIMITS, CURRENT_LIMITS = 0x10, 0x11, 0x12
REQUEST, SERIAL_NUMBER, MODEL_NUMBER, HARDWARE_STATUS = 0x60, 0x61, 0x62, 0x68
SOFTWARE_VERSION, HEARTBEAT_SET, HEARTBEAT_FREQUENCY = 0x6C, 0x91, 0x92
STANDBY, DISABLED, M_POSITION, M_VELOCITY, M_CURRENT = 0x00, 0x01, 0x02, 0x03, 0x04
ZERO_VELOCITY, POSITION_VELOCITY, POSITION_HOLD = 0x15, 0x1C, 0x1D
KNOWN_MODES = {STANDBY, DISABLED, M_POSITION, M_VELOCITY, M_CURRENT, 0x13, 0x14, ZERO_VELOCITY, 0x17, 0x18, 0x1A}
KNOWN_MODES |= {POSITION_VELOCITY, POSITION_HOLD, 0x26}
STOPPED_MODES = {STANDBY, DISABLED, ZERO_VELOCITY, POSITION_HOLD}
DEMAND_MODE = {VELOCITY: M_VELOCITY, POSITION: M_POSITION, CURRENT: M_CURRENT}


def crc8(data: bytes) -> int:
    """CRC-8 as the protocol documents it: polynomial 0x4D, input and output
    reflected, register starting at 0x00, result XORed with 0xFF. Bitwise, on
    the reflected polynomial (0x4D mirrored is 0xB2)."""
    reg = 0x00
    for byte in data:
        reg ^= byte
        for _ in range(8):
            reg = (reg >> 1) ^ 0xB2 if reg & 1 else reg >> 1
    return reg ^ 0xFF


def frame(device: int, packet: int, data: bytes) -> bytes:
    body = data + bytes((packet, device, len(data) + 4))
    return cobs.encode(body + bytes((crc8(body),))) + b"\x00"


def unframe(raw: bytes) -> tuple[int, int, bytes] | None:
    """(device, packet, data) of one received frame, None if it does not check."""
    try:
        body = cobs.decode(raw)
    except cobs.DecodeError:
        return None
    if len(body) < 4 or crc8(body[:-1]) != body[-1] or body[-2] != len(body):
        return None
    return body[-3], body[-4], bytes(body[:-4])


@dataclass
class Actuator:
    """One device: its state in its own units (rad or mm), limits and heartbeat."""

    device: int
    pos_limits: tuple[float, float]  # (min, max)
    vel_limit: float
    cur_limit: float  # mA
    position: float
    velocity: float = 0.0
    current: float = 0.0
    mode: int = STANDBY
    demand_velocity: float = 0.0
    demand_position: float | None = None
    demand_current: float = 0.0
    demand_t: float = 0.0
    status_flags: int = 0
    heartbeat: list[int] = field(default_factory=list)
    heartbeat_hz: int = 0
    heartbeat_dead: bool = False  # stopped once: does not restart (SDK note)
    next_beat: float = 0.0
    is_jaw: bool = False

    def value(self, packet: int) -> bytes | None:
        """The data of the packet this device sends for ``packet``, None if it has none."""
        if packet == POSITION:
            return struct.pack("<f", self.position)
        if packet == VELOCITY:
            return struct.pack("<f", self.velocity)
        if packet == CURRENT:
            return struct.pack("<f", self.current)
        if packet == MODE:
            return bytes((self.mode,))
        if packet == POSITION_LIMITS:
            return struct.pack("<2f", self.pos_limits[1], self.pos_limits[0])
        if packet == VELOCITY_LIMITS:
            return struct.pack("<2f", self.vel_limit, -self.vel_limit)
        if packet == CURRENT_LIMITS:
            return struct.pack("<2f", self.cur_limit, -self.cur_limit)
        if packet == HARDWARE_STATUS:
            return struct.pack("<I", self.status_flags)
        if packet == SOFTWARE_VERSION:
            return bytes((5, 3, 5))
        if packet in (SERIAL_NUMBER, MODEL_NUMBER):
            return struct.pack("<f", float(4000 + self.device))
        return None


def _r(deg: float) -> float:
    return deg * 3.141592653589793 / 180.0


#: Devices of each arm: id -> (position limits, speed limit, current limit mA, start position).
#: Alpha 5: the SDK URDF's limits, speeds as quoted in alpha issue #44 (30 deg/s, wrist 50 deg/s);
#: jaw 0-15 mm. Bravo 7: the SDK's v1 URDF ranges; speeds, currents and the jaw's 0-35 mm are
#: assumptions (not published). See /work/shared/spec/bluerov2_reach.md.
ARMS: dict[str, dict[int, tuple[tuple[float, float], float, float, float]]] = {
    "alpha5": {
        0x01: ((0.0, 15.0), 20.0, 800.0, 12.0),
        0x02: ((0.0, 6.2), _r(50), 1000.0, 3.0),
        0x03: ((0.0, 3.5), _r(30), 1500.0, 0.5),
        0x04: ((0.0, 3.8), _r(30), 1500.0, 1.6),
        0x05: ((0.0, 6.3), _r(30), 1500.0, 3.0),
    },
    "bravo7": {
        0x01: ((0.0, 35.0), 20.0, 1500.0, 30.0),
        0x02: ((0.0, 6.2), _r(50), 2000.0, 3.0),
        0x03: ((0.0, 3.2), _r(30), 3000.0, 1.5),
        0x04: ((0.0, 6.2), _r(30), 3000.0, 3.0),
        0x05: ((0.0, 3.2), _r(30), 4000.0, 1.0),
        0x06: ((0.0, 3.2), _r(30), 4000.0, 1.6),
        0x07: ((0.0, 6.3), _r(30), 4000.0, 3.0),
    },
}


class ArmPeer:
    """The arm's devices, what they answer and how they move."""

    def __init__(self, arm: str, velocity_timeout: float | None) -> None:
        self.devices = {
            d: Actuator(d, lim, vmax, imax, start, is_jaw=d == 0x01)
            for d, (lim, vmax, imax, start) in ARMS[arm].items()
        }
        self.velocity_timeout = velocity_timeout
        self.lock = threading.Lock()
        self.out: list[bytes] = []
        self.object_mm: float | None = None
        self.corrupt: list[str] = []
        self.stalled = False
        self.rx_counts: dict[str, int] = {}
        self.rx_bad = 0
        self.velocity_times: list[float] = []
        self.tx_frames = 0
        self.tx_dropped = 0

    # -------------------------------------------------------------- received packets
    def receive(self, raw: bytes, now: float) -> None:
        got = unframe(raw)
        if got is None:
            self.rx_bad += 1
            return
        device, packet, data = got
        key = f"0x{packet:02X}"
        self.rx_counts[key] = self.rx_counts.get(key, 0) + 1
        if packet == VELOCITY:
            self.velocity_times.append(now)
            self.velocity_times = self.velocity_times[-2000:]
        if device != 0xFF and device not in self.devices:
            return  # nobody on the link has that id
        targets = list(self.devices.values()) if device == 0xFF else [self.devices[device]]
        for dev in targets:
            self._apply(dev, packet, data, now)

    def _apply(self, dev: Actuator, packet: int, data: bytes, now: float) -> None:
        if packet == REQUEST:
            for pid in data:
                value = dev.value(pid)
                if value is not None:
                    self.send(dev.device, pid, value)
        elif packet == MODE and len(data) == 1:
            if data[0] in KNOWN_MODES and not dev.status_flags:
                dev.mode = data[0]
                if dev.mode in STOPPED_MODES:
                    dev.demand_velocity, dev.demand_current = 0.0, 0.0
        elif packet in DEMAND_MODE and len(data) == 4:
            if dev.mode == DISABLED or dev.status_flags:
                return  # disabled: demands are ignored until the mode is changed
            (value,) = struct.unpack("<f", data)
            if value != value:
                return
            dev.mode = DEMAND_MODE[packet]
            dev.demand_t = now
            if packet == VELOCITY:
                dev.demand_velocity = max(-dev.vel_limit, min(dev.vel_limit, value))
            elif packet == POSITION:
                lo, hi = dev.pos_limits
                dev.demand_position = max(lo, min(hi, value))
            else:
                dev.demand_current = max(-dev.cur_limit, min(dev.cur_limit, value))
        elif packet == HEARTBEAT_SET:
            dev.heartbeat = [p for p in data[:10] if p]
        elif packet == HEARTBEAT_FREQUENCY and len(data) == 1:
            if data[0] == 0:
                if dev.heartbeat_hz:
                    dev.heartbeat_dead = True
                dev.heartbeat_hz = 0
            elif not dev.heartbeat_dead:
                dev.heartbeat_hz = data[0]
                dev.next_beat = now

    def send(self, device: int, packet: int, data: bytes) -> None:
        raw = bytearray(frame(device, packet, data))
        if self.corrupt:
            kind = self.corrupt.pop(0)
            if kind == "crc":
                raw[-2] ^= 0x5A if raw[-2] ^ 0x5A else 0x33  # the CRC byte, never made 0
            else:
                raw[0] = min(len(raw) + 5, 0xFE)  # a COBS code pointing past the frame
        self.out.append(bytes(raw))
        self.tx_frames += 1

    # -------------------------------------------------------------- physics
    def step(self, now: float, dt: float) -> None:
        for dev in self.devices.values():
            self._move(dev, now, dt)
            if dev.heartbeat_hz and dev.heartbeat and now >= dev.next_beat:
                dev.next_beat = max(dev.next_beat + 1.0 / dev.heartbeat_hz, now - 1.0 / dev.heartbeat_hz)
                for pid in dev.heartbeat:
                    value = dev.value(pid)
                    if value is not None:
                        self.send(dev.device, pid, value)

    def _move(self, dev: Actuator, now: float, dt: float) -> None:
        lo, hi = dev.pos_limits
        accel = ACCEL * (10.0 if dev.is_jaw else 1.0)
        if dev.mode == M_VELOCITY:
            stale = self.velocity_timeout is not None and now - dev.demand_t > self.velocity_timeout
            target = 0.0 if stale else dev.demand_velocity
        elif dev.mode == M_POSITION and dev.demand_position is not None:
            err = dev.demand_position - dev.position
            target = max(-dev.vel_limit, min(dev.vel_limit, 4.0 * err))
        elif dev.mode == M_CURRENT:
            target = (1.0 if dev.demand_current > 0 else -1.0 if dev.demand_current < 0 else 0.0) * dev.vel_limit
        else:
            target = 0.0
        step = accel * dt
        dev.velocity += max(-step, min(step, target - dev.velocity))
        new = dev.position + dev.velocity * dt
        blocked = False
        if new <= lo or new >= hi:
            new = max(lo, min(hi, new))
            blocked = True
        if dev.is_jaw and self.object_mm is not None and dev.position >= self.object_mm >= new:
            new, blocked = self.object_mm, True
        dev.position = new
        if blocked:
            dev.velocity = 0.0
        pushing = blocked and target != 0.0
        if dev.is_jaw and pushing:
            dev.current = dev.demand_current if dev.mode == M_CURRENT else STALL_CURRENT_MA * (1 if target > 0 else -1)
        else:
            dev.current = 80.0 + 400.0 * abs(dev.velocity) / max(dev.vel_limit, 1e-9)
            dev.current *= 1.0 if dev.velocity >= 0 else -1.0

    # -------------------------------------------------------------- control
    def command(self, msg: dict[str, Any]) -> str | None:
        """Handle one stdin command; returns a line to print, if any."""
        cmd = msg.get("cmd")
        if cmd == "stall":
            self.stalled = True
        elif cmd == "resume":
            self.stalled = False
        elif cmd == "corrupt":
            self.corrupt += [str(msg.get("kind", "crc"))] * int(msg.get("count", 1))
        elif cmd == "joint_fault":
            dev = self.devices[int(msg["device"])]
            dev.status_flags = int(msg.get("flags", 1))
            dev.mode, dev.demand_velocity, dev.demand_current = DISABLED, 0.0, 0.0
        elif cmd == "clear_fault":
            self.devices[int(msg["device"])].status_flags = 0
        elif cmd == "object":
            self.object_mm = None if msg.get("width_mm") is None else float(msg["width_mm"])
        elif cmd == "report":
            return "REPORT " + json.dumps(self.report())
        return None

    def report(self) -> dict[str, Any]:
        now = time.monotonic()
        recent = [t for t in self.velocity_times if t > now - 1.0]
        return {
            "t": now,
            "devices": {
                str(d.device): {
                    "position": d.position,
                    "velocity": d.velocity,
                    "current_ma": d.current,
                    "mode": d.mode,
                    "demand_velocity": d.demand_velocity,
                    "demand_age_s": now - d.demand_t if d.demand_t else None,
                    "heartbeat": d.heartbeat,
                    "heartbeat_hz": d.heartbeat_hz,
                    "status_flags": d.status_flags,
                }
                for d in self.devices.values()
            },
            "rx_counts": self.rx_counts,
            "rx_bad": self.rx_bad,
            "velocity_packets_last_s": len(recent),
            "tx_frames": self.tx_frames,
            "tx_dropped": self.tx_dropped,
        }


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--transport", choices=["serial", "udp"], default="serial")
    ap.add_argument("--port", type=int, default=0, help="UDP port on 127.0.0.1 (0: any free one)")
    ap.add_argument("--arm", choices=sorted(ARMS), default="alpha5")
    ap.add_argument("--baudrate", type=int, default=115200, help="serial line rate the pty is limited to")
    ap.add_argument("--velocity-timeout", type=float, default=None)
    ap.add_argument("--max-runtime", type=float, default=300.0)
    args = ap.parse_args(argv)
    peer = ArmPeer(args.arm, args.velocity_timeout)
    quit_flag = threading.Event()

    def commands() -> None:
        for line in sys.stdin:
            try:
                msg = json.loads(line)
            except json.JSONDecodeError:
                continue
            if msg.get("cmd") == "quit":
                break
            with peer.lock:
                out = peer.command(msg)
            if out:
                print(out, flush=True)
        quit_flag.set()

    threading.Thread(target=commands, daemon=True).start()
    sock: socket.socket | None = None
    master = slave = -1
    if args.transport == "udp":
        sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        sock.bind(("127.0.0.1", args.port))
        sock.setblocking(False)
        print(f"READY {sock.getsockname()[1]}", flush=True)
        fd = sock.fileno()
    else:
        master, slave = pty.openpty()
        tty.setraw(slave)
        os.set_blocking(master, False)  # a full pty buffer drops frames instead of hanging the peer
        print(f"READY {os.ttyname(slave)}", flush=True)
        fd = master
    host: tuple[str, int] | None = None
    pending = b""
    line_budget = 0.0  # bytes the serial line may still send now
    rate = args.baudrate / 10.0  # bytes/s of an 8N1 line
    t0 = last = line_t = time.monotonic()
    try:
        while not quit_flag.is_set() and time.monotonic() - t0 < args.max_runtime:
            readable, _, _ = select.select([fd], [], [], STEP)
            now = time.monotonic()
            with peer.lock:
                if readable:
                    try:
                        if sock is not None:
                            data, host = sock.recvfrom(65536)
                        else:
                            data = os.read(master, 4096)
                    except (BlockingIOError, OSError):
                        data = b""
                    if not peer.stalled:
                        *frames, pending = (pending + data).split(b"\x00")
                        for raw in frames:
                            if raw:
                                peer.receive(raw, now)
                        pending = pending[-512:]
                if now - last >= STEP:
                    peer.step(now, now - last)
                    last = now
                out, peer.out = peer.out, []
                stalled = peer.stalled
            if stalled or not out:
                continue
            if sock is not None:
                if host is not None:
                    try:
                        sock.sendto(b"".join(out), host)
                    except OSError:
                        pass
                continue
            line_budget = min(line_budget + rate * (now - line_t), rate * 0.05)
            line_t = now
            chunk = b""
            dropped = 0
            for f in out:
                if len(chunk) + len(f) <= line_budget:
                    chunk += f
                else:
                    dropped += 1
            line_budget -= len(chunk)
            try:
                os.write(master, chunk)
            except OSError:
                dropped = len(out)  # nobody reads the pty: its buffer is full
            if dropped:
                with peer.lock:
                    peer.tx_dropped += dropped
    finally:
        if sock is not None:
            sock.close()
        else:
            os.close(master)
            os.close(slave)
    return 0


if __name__ == "__main__":
    sys.exit(main())
