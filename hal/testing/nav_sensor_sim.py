"""Water Linked DVL A50 and MicroStrain AHRS simulators speaking the real byte formats.

    python -m hal.testing.nav_sensor_sim dvl-tcp --port 16171      # JSON lines over TCP (127.0.0.1)
    python -m hal.testing.nav_sensor_sim dvl-serial                # wrz lines on a new pseudo-terminal
    python -m hal.testing.nav_sensor_sim ahrs-serial               # MIP packets on a new pseudo-terminal

Prints ``READY <where>`` (the TCP port or the pty device path) once serving.
Output rate ``--rate`` Hz; constant body velocity ``--velocity vx,vy,vz``.
stdin, one JSON object per line: ``{"cmd": "corrupt", "kind": "crc"|"json"|"absurd"|"garbage"}``
(queued: each next report is corrupted that way), ``{"cmd": "invalid"}`` (next DVL report
flagged invalid), ``{"cmd": "silence"}``, ``{"cmd": "resume"}``, ``{"cmd": "quit"}``.
Quitting closes the pty master: to the reader the serial port disappears.
"""

from __future__ import annotations

import argparse
import json
import os
import pty
import socket
import sys
import threading
import time
import tty
from dataclasses import dataclass, field

from hal.drivers.ahrs_microstrain import ahrs_packet
from hal.drivers.dvl_waterlinked import format_wrz


def dvl_json(v: tuple[float, float, float], valid: bool, altitude: float, corrupt: str | None) -> bytes:
    rep = {
        "time": 100.0,
        "vx": v[0],
        "vy": v[1],
        "vz": v[2],
        "fom": 0.002,
        "altitude": altitude,
        "velocity_valid": valid,
        "status": 0,
        "format": "json_v3.1",
        "type": "velocity",
        "time_of_validity": int(time.time() * 1e6),
        "time_of_transmission": int(time.time() * 1e6),
    }
    if corrupt == "absurd":
        rep["vx"] = 250.0
    text = json.dumps(rep)
    if corrupt in ("json", "crc"):
        text = text[: len(text) // 2]
    if corrupt == "garbage":
        text = "\x00\xff\x13garbage"
    return (text + "\r\n").encode("latin-1")


def dvl_wrz(v: tuple[float, float, float], valid: bool, altitude: float, corrupt: str | None) -> bytes:
    line = format_wrz(v[0] if corrupt != "absurd" else 250.0, v[1], v[2], valid, altitude)
    if corrupt == "crc":
        line = line.replace(f"{v[1]:.3f}", f"{v[1] + 0.5:.3f}", 1)  # payload changed, checksum kept
    elif corrupt == "json":
        line = line[: len(line) // 2]
    elif corrupt == "garbage":
        line = "wrz,\x00\xff"
    return (line + "\r\n").encode("latin-1")


def ahrs(rpy: tuple[float, float, float], gyro: tuple[float, float, float], corrupt: str | None) -> bytes:
    pkt = bytearray(ahrs_packet(rpy, gyro))
    if corrupt in ("crc", "json"):
        pkt[-1] ^= 0x5A
    elif corrupt == "absurd":
        pkt = bytearray(ahrs_packet((rpy[0], rpy[1], 99.0), gyro))
    elif corrupt == "garbage":
        pkt = bytearray(b"\x75\x75\x65\x01\x02") + pkt
    return bytes(pkt)


@dataclass
class PeerControl:
    """What the test asked the peer on stdin: faults to play."""

    #: Kinds of the next corrupt messages, oldest first (``crc``...).
    corrupt: list[str] = field(default_factory=list)
    #: Send the next message with the velocity flagged invalid.
    invalid: bool = False
    #: Send nothing until resumed.
    silent: bool = False
    quit: bool = False


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("mode", choices=["dvl-tcp", "dvl-serial", "ahrs-serial"])
    ap.add_argument("--port", type=int, default=0, help="TCP port (0: any free one)")
    ap.add_argument("--rate", type=float, default=20.0)
    ap.add_argument("--velocity", default="0.2,0.0,0.05")
    ap.add_argument("--altitude", type=float, default=3.0)
    ap.add_argument("--max-runtime", type=float, default=300.0)
    args = ap.parse_args(argv)
    vx, vy, vz = (float(x) for x in args.velocity.split(","))
    vel = (vx, vy, vz)
    ctl = PeerControl()
    lock = threading.Lock()

    def commands() -> None:
        for line in sys.stdin:
            try:
                msg = json.loads(line)
            except json.JSONDecodeError:
                continue
            with lock:
                cmd = msg.get("cmd")
                if cmd == "corrupt":
                    ctl.corrupt.append(msg.get("kind", "crc"))
                elif cmd == "invalid":
                    ctl.invalid = True
                elif cmd in ("silence", "resume"):
                    ctl.silent = cmd == "silence"
                elif cmd == "quit":
                    break
        ctl.quit = True

    threading.Thread(target=commands, daemon=True).start()
    server = None
    if args.mode == "dvl-tcp":
        server = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
        server.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        server.bind(("127.0.0.1", args.port))
        server.listen(1)
        server.settimeout(0.2)
        print(f"READY {server.getsockname()[1]}", flush=True)
    else:
        master, slave = pty.openpty()
        tty.setraw(slave)
        print(f"READY {os.ttyname(slave)}", flush=True)
    t0 = time.monotonic()
    client = None
    period = 1.0 / args.rate
    next_t = t0
    try:
        while not ctl.quit and time.monotonic() - t0 < args.max_runtime:
            next_t = max(next_t + period, time.monotonic() - period)  # no catch-up bursts
            time.sleep(max(0.0, next_t - time.monotonic()))
            if server is not None and client is None:
                try:
                    client, _ = server.accept()
                except TimeoutError:
                    continue
            with lock:
                corrupt = ctl.corrupt.pop(0) if ctl.corrupt else None
                valid = not ctl.invalid
                ctl.invalid = False
                silent = ctl.silent
            if silent:
                continue
            t = time.monotonic() - t0
            if args.mode == "dvl-tcp":
                data = dvl_json(vel, valid, args.altitude, corrupt)
            elif args.mode == "dvl-serial":
                data = dvl_wrz(vel, valid, args.altitude, corrupt)
            else:
                data = ahrs((0.01, -0.02, 0.1 * t % 3.0), (0.0, 0.0, 0.1), corrupt)
            try:
                if client is not None:
                    client.sendall(data)
                else:
                    os.write(master, data)
            except OSError:
                client = None  # TCP reader went away; wait for the next one
    finally:
        for h in (client, server):
            if h is not None:
                h.close()
        if server is None:
            os.close(master)
            os.close(slave)
    return 0


if __name__ == "__main__":
    sys.exit(main())
