"""A CiA 402 drive simulator on canopen's LocalNode, for tests and bench checks
without hardware. Run it as its own process::

    python -m hal.testing.cia402_sim --interface udp_multicast --channel 239.74.163.2 \\
        --port 43113 --nodes 2,3,4 [--eds hal/data/cia402_minimal.eds]

Each node answers SDO, obeys NMT, produces its heartbeat once 0x1017 is set,
watches the host heartbeat configured in 0x1016 (FAULT with EMCY 0x8130 when
it stops), applies RPDO1 (controlword + target velocity) through the CiA 402 state machine
(:class:`hal.drivers.cia402.Cia402Machine`) and sends TPDO1/TPDO2 with the
mapping and event timer the host configured. Motion: velocity follows the
target with the profile acceleration (0x6083), quick stop with 0x6085; a motor
pushing past ``contact`` (rad, optional) stalls and its current climbs.

Fault injection, one JSON object per line on stdin:
``{"cmd": "fault", "node": 3, "code": 8992}`` (drive FAULT + EMCY),
``{"cmd": "silence", "node": 3}`` (heartbeat stops), ``{"cmd": "resume", "node": 3}``,
``{"cmd": "contact", "node": 3, "counts": 500}``, ``{"cmd": "quit"}``.
The simulator prints ``READY`` on stdout once its nodes are on the bus.
"""

from __future__ import annotations

import argparse
import json
import sys
import threading
import time
from pathlib import Path

import canopen

from hal.drivers.canbus import open_can_bus
from hal.drivers.cia402 import Cia402Machine, State

DEFAULT_EDS = str(Path(__file__).resolve().parent.parent / "data" / "cia402_minimal.eds")
STEP = 0.005  # s, physics step


class SimDrive:
    """One simulated drive: LocalNode + state machine + first-order motion."""

    def __init__(self, network: canopen.Network, node_id: int, eds: str) -> None:
        self.node = canopen.LocalNode(node_id, eds)
        network.add_node(self.node)
        self.machine = Cia402Machine()
        self.machine.boot()
        self.lock = threading.Lock()
        self.position = 0.0  # counts
        self.velocity = 0.0  # velocity units
        self.target_velocity = 0
        self.current_permille = 0
        self.contact: float | None = None
        self.error_code = 0
        self.pdo_ready = False
        self.silenced = False
        self._last_tx = 0.0
        self._last_nmt = self.node.nmt.state
        network.subscribe(0x200 + node_id, self._on_rpdo)
        self._network = network
        self._watched: int | None = None  # consumer heartbeat 0x1016:1 as configured by the host
        self._host_seen: float | None = None
        self.node.add_read_callback(self._on_sdo_read)

    def _on_sdo_read(self, index: int, subindex: int, od: object) -> int | None:
        """Live values for SDO reads of the drive's process data."""
        if index == 0x6061:
            return int.from_bytes(self.node.data_store.get(0x6060, {}).get(0, b"\x00"), "little", signed=True)
        if index == 0x6041:
            return self.machine.statusword
        if index == 0x6064:
            return int(self.position)
        if index == 0x606C:
            return int(self.velocity)
        return None

    def _on_rpdo(self, can_id: int, data: bytearray, timestamp: float) -> None:
        if self.node.nmt.state != "OPERATIONAL" or len(data) < 6:
            return
        cw = int.from_bytes(data[0:2], "little")
        tv = int.from_bytes(data[2:6], "little", signed=True)
        with self.lock:
            self.machine.apply_controlword(cw)
            self.target_velocity = tv

    def _on_host_heartbeat(self, can_id: int, data: bytearray, timestamp: float) -> None:
        self._host_seen = time.monotonic()

    def _watch_host(self, now: float) -> None:
        """CiA 301 heartbeat consumer: fault (EMCY 0x8130) when the watched producer goes silent."""
        try:
            raw = int.from_bytes(self.node.data_store.get(0x1016, {}).get(1, b"\0\0\0\0"), "little")
        except (TypeError, ValueError):
            return
        if raw != self._watched:
            if self._watched:
                self._network.unsubscribe(0x700 + ((self._watched >> 16) & 0x7F), self._on_host_heartbeat)
            self._watched, self._host_seen = raw, None
            if raw:
                self._network.subscribe(0x700 + ((raw >> 16) & 0x7F), self._on_host_heartbeat)
        limit = (raw & 0xFFFF) / 1000.0
        if raw and limit > 0 and self._host_seen is not None and now - self._host_seen > limit:
            self._host_seen = None  # one fault per loss; monitoring restarts with the next heartbeat
            if self.machine.cia_state not in (State.FAULT, State.FAULT_REACTION_ACTIVE):
                self.fault(0x8130)

    def fault(self, code: int) -> None:
        with self.lock:
            self.machine.raise_fault()
            self.error_code = code
            self.node.sdo[0x603F].raw = code
        self.node.emcy.send(code, 0x01)

    def step(self, now: float) -> None:
        self._watch_host(now)
        nmt = self.node.nmt.state
        if nmt != self._last_nmt:
            self._last_nmt = nmt
            if nmt == "OPERATIONAL":
                self.node.tpdo.read()  # host may have remapped over SDO
                self.pdo_ready = True
            else:
                self.pdo_ready = False
        with self.lock:
            st = self.machine.cia_state
            if st == State.FAULT_REACTION_ACTIVE:
                self.machine.fault_reaction_done()
                st = self.machine.cia_state
            if st == State.OPERATION_ENABLED:
                target, accel = float(self.target_velocity), float(self.node.sdo[0x6083].raw)
            else:
                target, accel = 0.0, float(self.node.sdo[0x6085].raw)
                if st not in (State.QUICK_STOP_ACTIVE, State.FAULT_REACTION_ACTIVE):
                    self.velocity = 0.0
            dv = max(-accel * STEP, min(accel * STEP, target - self.velocity))
            self.velocity += dv
            self.position += self.velocity * STEP
            load = 0.0
            if self.contact is not None and self.position > self.contact and self.velocity > 0:
                self.position = self.contact
                load = min(900.0, 200.0 + abs(target) * 0.5)
                self.velocity = 0.0
            self.current_permille = int(min(1000.0, 50.0 + abs(self.velocity) * 0.05 + load)) if st == State.OPERATION_ENABLED else 0
            sw = self.machine.statusword
        if not self.pdo_ready:
            return
        period = max(0.001, self.node.tpdo[1].event_timer / 1000.0 if self.node.tpdo[1].event_timer else 0.01)
        if now - self._last_tx >= period:
            self._last_tx = now
            self._send(sw)

    def _send(self, sw: int) -> None:
        values = {0x6041: sw, 0x606C: int(self.velocity), 0x6064: int(self.position), 0x6078: self.current_permille}
        for num in (1, 2):
            tp = self.node.tpdo[num]
            if not tp.enabled:
                continue
            for var in tp:
                if var.index in values:
                    var.raw = values[var.index]
            tp.transmit()

    def set_silenced(self, silenced: bool) -> None:
        self.silenced = silenced
        if silenced:
            self.node.nmt.stop_heartbeat()
        else:
            self.node.nmt.start_heartbeat(self.node.sdo[0x1017].raw)


def _read_commands(drives: dict[int, SimDrive], stop: threading.Event) -> None:
    for line in sys.stdin:
        try:
            msg = json.loads(line)
        except json.JSONDecodeError:
            continue
        cmd, node = msg.get("cmd"), drives.get(int(msg.get("node", 0)))
        if cmd == "quit":
            break
        if node is None:
            continue
        if cmd == "fault":
            node.fault(int(msg.get("code", 0x1000)))
        elif cmd == "silence":
            node.set_silenced(True)
        elif cmd == "resume":
            node.set_silenced(False)
        elif cmd == "contact":
            with node.lock:
                node.contact = float(msg["counts"])
    stop.set()


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--interface", default="udp_multicast")
    ap.add_argument("--channel", default="239.74.163.2")
    ap.add_argument("--port", type=int, default=43113)
    ap.add_argument("--nodes", default="2")
    ap.add_argument("--eds", default=DEFAULT_EDS)
    ap.add_argument("--max-runtime", type=float, default=600.0, help="s, exits by itself after this")
    args = ap.parse_args(argv)
    opts = {"port": args.port, "hop_limit": 0} if args.interface == "udp_multicast" else {}
    network = canopen.Network(open_can_bus(args.interface, args.channel, **opts))
    network.NOTIFIER_CYCLE = 0.1
    network.connect()
    drives = {int(n): SimDrive(network, int(n), args.eds) for n in args.nodes.split(",")}
    stop = threading.Event()
    threading.Thread(target=_read_commands, args=(drives, stop), daemon=True).start()
    for d in drives.values():
        d.node.nmt.send_command(0x81)  # reset: INITIALISING, boot-up message
        d.node.nmt.send_command(0x80)  # -> PRE-OPERATIONAL
    print("READY", flush=True)
    t0 = time.monotonic()
    next_t = t0
    try:
        while not stop.is_set() and time.monotonic() - t0 < args.max_runtime:
            now = time.monotonic()
            for d in drives.values():
                d.step(now)
            next_t += STEP
            time.sleep(max(0.0, next_t - time.monotonic()))
    finally:
        for d in drives.values():
            d.node.nmt.stop_heartbeat()
        network.disconnect()
    return 0


if __name__ == "__main__":
    sys.exit(main())
