"""An ArduSub autopilot peer for tests and dry runs without a vehicle.

    python -m hal.testing.ardusub_peer --url tcpin:127.0.0.1:5760 [--profile 4.0|4.5]
        [--position gps|dvl|none] [--prearm-fail "Compass not calibrated"] [--sitl]

Behaves as ArduSub does towards a ground station (see :mod:`hal.testing.ardusub_fw`
for every firmware fact modelled and where it comes from): it streams nothing
but HEARTBEAT until asked, refuses GUIDED without a position estimate, fails
arming on pre-arm checks with STATUSTEXT, moves HOME at arming, ignores the
setpoint yaw rate in the 4.0 profile, treats sticks as thrust, disarms on a lost
GCS heartbeat (and, unless ``--sitl``, on lost pilot input), and can restart.

``--url``: ``tcpin:HOST:PORT`` (listen, like SITL's TCP 5760; one client at a
time) or ``udpout:HOST:PORT`` (send to the ground station). Prints ``READY``.

stdin, one JSON object per line:
``{"cmd": "restart", "down_s": 1.0}`` (autopilot reboot: the TCP connection
and listener close, nothing is sent for ``down_s``, then it boots afresh),
``{"cmd": "silence"}`` / ``{"cmd": "resume"}`` (tether cut: nothing in or out),
``{"cmd": "set", "position": "none"}`` (lose / regain the position estimate),
``{"cmd": "report"}`` (prints ``REPORT {json}``: state and what the GCS sent),
``{"cmd": "quit"}``.
"""

from __future__ import annotations

import argparse
import json
import math
import queue
import select
import socket
import sys
import threading
import time

from pymavlink.dialects.v20 import ardupilotmega as mavlink2

from hal.testing.ardusub_fw import Firmware


class _Sink:
    def __init__(self) -> None:
        self.frames: list[bytes] = []

    def write(self, buf: bytes) -> None:
        self.frames.append(bytes(buf))


class Peer:
    """Socket side of the peer: one connection, a MAVLink codec, the firmware model."""

    def __init__(self, url: str, fw: Firmware) -> None:
        kind, _, rest = url.partition(":")
        host, _, port = rest.rpartition(":")
        if kind not in ("tcpin", "udpout") or not port.isdigit():
            raise SystemExit(f"--url must be tcpin:HOST:PORT or udpout:HOST:PORT, got {url!r}")
        self.kind, self.addr = kind, (host, int(port))
        self.fw = fw
        self.listener: socket.socket | None = None
        self.conn: socket.socket | None = None
        self.sink = _Sink()
        self.mav = mavlink2.MAVLink(self.sink, srcSystem=1, srcComponent=1)
        self.mav.robust_parsing = True
        self.connected_t: float | None = None
        self.first_msg: str | None = None
        self.first_gcs_hb_s: float | None = None
        self.gcs_hb_sysids: set[int] = set()
        self.setpoints = 0
        self.silent = False
        self.down_until = 0.0
        self._open()

    def _open(self) -> None:
        if self.kind == "tcpin":
            ls = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
            ls.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
            ls.bind(self.addr)
            ls.listen(1)
            ls.setblocking(False)
            self.listener = ls
        else:
            self.conn = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
            self.conn.setblocking(False)
            self._connected()

    def _connected(self) -> None:
        self.connected_t = time.monotonic()
        self.first_msg = None
        self.first_gcs_hb_s = None
        self.mav = mavlink2.MAVLink(self.sink, srcSystem=1, srcComponent=1)
        self.mav.robust_parsing = True

    def restart(self, down_s: float) -> None:
        for s in (self.conn, self.listener):
            if s is not None:
                s.close()
        self.conn = self.listener = None
        self.down_until = time.monotonic() + down_s

    def poll(self, timeout: float) -> None:
        now = time.monotonic()
        if self.conn is None and self.listener is None:
            if now < self.down_until:
                time.sleep(timeout)
                return
            self.fw.reboot(now)
            self._open()
        listener, conn = self.listener, self.conn
        if self.kind == "tcpin" and conn is None:
            if listener is None:
                return
            r, _, _ = select.select([listener], [], [], timeout)
            if r:
                self.conn, _ = listener.accept()
                self.conn.setblocking(False)
                self._connected()
            return
        if conn is None:
            return
        r, _, _ = select.select([conn], [], [], timeout)
        if not r:
            return
        try:
            data = conn.recv(65535)
        except (BlockingIOError, ConnectionRefusedError):
            return
        except OSError:
            data = b""
        if not data and self.kind == "tcpin":
            conn.close()
            self.conn = None  # ground station gone: wait for the next one
            return
        if self.silent:
            return
        for m in self.mav.parse_buffer(data) or []:
            kind = m.get_type()
            if kind == "BAD_DATA":
                continue
            if self.first_msg is None:
                self.first_msg = kind
            if kind == "HEARTBEAT":
                self.gcs_hb_sysids.add(m.get_srcSystem())
                if self.first_gcs_hb_s is None and m.get_srcSystem() == 255:
                    self.first_gcs_hb_s = time.monotonic() - (self.connected_t or 0.0)
            if kind == "SET_POSITION_TARGET_LOCAL_NED":
                self.setpoints += 1
            self.fw.handle(m)

    def flush(self) -> None:
        out, self.fw.out = self.fw.out, []
        if self.conn is None or self.silent:
            return
        for name, args in out:
            getattr(self.mav, name + "_send")(*args)
        frames, self.sink.frames = self.sink.frames, []
        try:
            for f in frames:
                if self.kind == "udpout":
                    self.conn.sendto(f, self.addr)
                else:
                    self.conn.sendall(f)
        except OSError:
            pass

    def report(self) -> dict:
        fw = self.fw
        return {
            "armed": fw.armed,
            "mode": fw.mode,
            "yaw_deg": math.degrees(fw.yaw),
            "depth": fw.depth,
            "north": fw.pos[0],
            "east": fw.pos[1],
            "home": fw.home,
            "vel": fw.vel,
            "streams": sorted(fw.streams),
            "first_msg": self.first_msg,
            "first_gcs_heartbeat_s": self.first_gcs_hb_s,
            "gcs_heartbeat_sysids": sorted(self.gcs_hb_sysids),
            "setpoints": self.setpoints,
            "connected": self.conn is not None,
            "counts": fw.counts,
        }


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--url", required=True)
    ap.add_argument("--profile", choices=("4.0", "4.5"), default="4.0")
    ap.add_argument("--position", choices=("gps", "dvl", "none"), default="dvl")
    ap.add_argument("--prearm-fail", default=None, help="pre-arm failure text (arming is refused)")
    ap.add_argument("--sitl", action="store_true", help="no pilot-input failsafe (as in ArduSub SITL builds)")
    ap.add_argument("--max-runtime", type=float, default=300.0)
    args = ap.parse_args(argv)
    t0 = time.monotonic()
    fw = Firmware(
        profile=args.profile, position_source=args.position, prearm_fail=args.prearm_fail, hardware=not args.sitl
    )
    fw.reboot(t0)
    peer = Peer(args.url, fw)
    commands: queue.Queue = queue.Queue()

    def read_stdin() -> None:
        for line in sys.stdin:
            try:
                commands.put(json.loads(line))
            except json.JSONDecodeError:
                continue
        commands.put({"cmd": "quit"})

    threading.Thread(target=read_stdin, daemon=True).start()
    print("READY", flush=True)
    while time.monotonic() - t0 < args.max_runtime:
        try:
            cmd = commands.get_nowait()
        except queue.Empty:
            cmd = None
        if cmd is not None:
            c = cmd.get("cmd")
            if c == "quit":
                break
            if c == "restart":
                peer.restart(float(cmd.get("down_s", 1.0)))
            elif c == "silence":
                peer.silent = True
            elif c == "resume":
                peer.silent = False
            elif c == "set" and "position" in cmd:
                fw.position_source = cmd["position"]
            elif c == "report":
                print("REPORT " + json.dumps(peer.report()), flush=True)
        peer.poll(0.01)
        if peer.conn is not None or peer.listener is not None:
            fw.step(time.monotonic())
            peer.flush()
    for s in (peer.conn, peer.listener):
        if s is not None:
            s.close()
    return 0


if __name__ == "__main__":
    sys.exit(main())
