"""A CiA 402 drive simulator on canopen's LocalNode, for tests and bench checks
without hardware. Run it as its own process::

    python -m hal.testing.cia402_sim --interface udp_multicast --channel 239.74.163.2 \\
        --port 43113 --nodes 2,3,4 [--eds hal/data/cia402_minimal.eds]

It behaves like a drive, not like our driver expects (CiA 301 / CiA 402, as
small motion controllers such as Faulhaber's implement them):

* **Objects come from the EDS only.** An object or sub-index the file lacks
  does not exist: SDO access is refused (abort 0x06020000 / 0x06090011),
  writes to read-only objects too (0x06010002). Only the operating modes the
  file supports are accepted in 0x6060 (abort 0x06090030 otherwise); PDO
  mapping may only change while the PDO is invalid (COB-ID bit 31 set,
  abort 0x06040043 otherwise).
* **Silent until asked.** After boot (boot-up message, a short NOT READY TO
  SWITCH ON transient, then PRE-OPERATIONAL) it sends no heartbeat until 0x1017
  is written and no PDO until NMT start. TPDOs follow their transmission type:
  254/255 with an event timer (sub-index 5, if the EDS has it) -> periodically
  and whenever the statusword changes; 254/255 without one -> only when a
  mapped value changes (a drive in steady motion does not resend its constant
  velocity); 1..240 -> on every n-th SYNC; 0 -> on SYNC when changed;
  252/253 (RTR) -> never. No TPDO is sent when entering OPERATIONAL.
* **Faults as drives fault.** The heartbeat consumer (0x1016:1) starts watching
  with the first heartbeat received; when it stops: EMCY 0x8130, error register
  bit 4, CiA 402 FAULT and, if OPERATIONAL, NMT PRE-OPERATIONAL (CiA 301 default
  error behaviour). A fault reset (controlword bit 7 rising) is refused while
  the cause persists; accepted, it clears 0x1001/0x603F and sends EMCY 0x0000.
  Fault codes are kept in 0x603F and the 0x1003 history if the EDS has them.

Motion: velocity follows the target with the profile acceleration (0x6083,
default 10000 units/s^2 if absent), quick stop with 0x6085; a motor pushing
past ``contact`` (counts, optional) stalls and its current climbs.

Fault injection, one JSON object per line on stdin:
``{"cmd": "fault", "node": 3, "code": 8992, "persist": false}`` (drive FAULT +
EMCY; ``persist`` keeps the cause until ``{"cmd": "clear", "node": 3}``),
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
from canopen.objectdictionary import ODArray, ODRecord
from canopen.pdo.base import PdoBase, PdoMaps
from canopen.sdo import SdoAbortedError, SdoVariable

from hal.drivers.canbus import open_can_bus
from hal.drivers.cia402 import Cia402Machine, State

DEFAULT_EDS = str(Path(__file__).resolve().parent.parent / "data" / "cia402_minimal.eds")
STEP = 0.005  # s, physics step
BOOT_TRANSIENT = 0.05  # s in NOT READY TO SWITCH ON after power-up
PDO_NOT_VALID = 0x80000000
ABORT_VALUE_RANGE = 0x06090030
ABORT_PARAMETER_INCOMPATIBLE = 0x06040043


def _register_bits(code: int) -> int:
    """Error register 0x1001 for an error code (CiA 301 bit meanings)."""
    reg = 0x01
    top = code >> 12
    reg |= {0x2: 0x02, 0x3: 0x04, 0x4: 0x08}.get(top, 0)
    if code & 0xFF00 in (0x8100, 0x8200):
        reg |= 0x10
    return reg


class SimDrive:
    """One simulated drive: LocalNode + state machine + first-order motion."""

    def __init__(self, network: canopen.Network, node_id: int, eds: str) -> None:
        self.node = canopen.LocalNode(node_id, eds)
        network.add_node(self.node)
        self._network = network
        self.machine = Cia402Machine()
        self.booted_at = time.monotonic()
        self.lock = threading.Lock()
        self.position = 0.0  # counts
        self.velocity = 0.0  # velocity units
        self.target_velocity = 0
        self.current_permille = 0
        self.contact: float | None = None
        self.error_code = 0
        self.error_register = 0
        self.fault_persists = False
        self.pdo_ready = False
        self.silenced = False
        self._last_nmt = self.node.nmt.state
        self._tx_last: dict[int, float] = {}
        self._tx_values: dict[int, tuple] = {}
        self._sync_count = 0
        self._watched: int | None = None  # consumer heartbeat 0x1016:1 as configured by the host
        self._host_seen: float | None = None
        self.node.add_read_callback(self._on_sdo_read)
        self.node.add_write_callback(self._on_sdo_write)
        network.subscribe(0x80, self._on_sync)

    # ------------------------------------------------------------------ SDO server side

    def _obj(self, index: int) -> bool:
        return index in self.node.object_dictionary

    def _on_sdo_read(self, index: int, subindex: int, od: object) -> int | None:
        """Live values for SDO reads of the drive's process data."""
        if index == 0x6061:
            return int.from_bytes(self.node.data_store.get(0x6060, {}).get(0, b"\x00"), "little", signed=True) or None
        if index == 0x6041:
            return self.statusword()
        if index == 0x6064:
            return int(self.position)
        if index == 0x606C:
            return int(self.velocity)
        if index == 0x1001:
            return self.error_register
        if index == 0x603F:
            return self.error_code
        return None

    def _on_sdo_write(self, index: int, subindex: int, od: object, data: bytes) -> None:
        """Refuse what a drive refuses (raising SdoAbortedError aborts the transfer)."""
        value = int.from_bytes(data, "little", signed=index == 0x6060)
        if index == 0x6060:
            supported = {3} | ({1} if self._obj(0x607A) else set())
            if value not in supported:
                raise SdoAbortedError(ABORT_VALUE_RANGE)
        elif 0x1600 <= index <= 0x17FF or 0x1A00 <= index <= 0x1BFF:
            comm = index - 0x200
            cob = (
                int.from_bytes(self.node.data_store.get(comm, {}).get(1, b""), "little")
                if comm in self.node.data_store
                else None
            )
            if cob is None:
                record = self.node.object_dictionary[comm]
                var = record[1] if isinstance(record, (ODRecord, ODArray)) else record
                cob = var.default if isinstance(var.default, int) else 0
            if not cob & PDO_NOT_VALID:
                raise SdoAbortedError(ABORT_PARAMETER_INCOMPATIBLE)
        elif (0x1400 <= index <= 0x15FF or 0x1800 <= index <= 0x19FF) and subindex == 2:
            if not (value <= 240 or value >= 252):
                raise SdoAbortedError(ABORT_VALUE_RANGE)

    # ------------------------------------------------------------------ PDOs

    def _on_rpdo(self, pdo_map: canopen.pdo.PdoMap) -> None:
        if self.node.nmt.state != "OPERATIONAL":
            return  # PDOs are only processed in OPERATIONAL
        values = {var.index: var.raw for var in pdo_map}
        with self.lock:
            if 0x60FF in values:
                self.target_velocity = int(values[0x60FF])
            if 0x6040 in values:
                cw = int(values[0x6040])
                if cw & 0x80 and self.machine.cia_state == State.FAULT and self._fault_cause_persists():
                    self.machine._last_cw = cw  # noqa: SLF001 - edge seen but refused: the cause persists
                    return
                before = self.machine.cia_state
                after = self.machine.apply_controlword(cw)
                if before == State.FAULT and after != State.FAULT:
                    self._clear_error()

    def _fault_cause_persists(self) -> bool:
        if self.fault_persists:
            return True
        if self.error_code == 0x8130:  # heartbeat lost: gone once the host is heard again (or no longer watched)
            return bool(self._watched) and self._host_seen is None
        return False

    def _clear_error(self) -> None:
        self.error_code = 0
        self.error_register = 0
        self.node.emcy.reset(0)

    def _on_sync(self, can_id: int, data: bytearray, timestamp: float) -> None:
        if self.node.nmt.state != "OPERATIONAL" or not self.pdo_ready:
            return
        self._sync_count += 1
        values = self._values()
        for num, tp in _maps(self.node.tpdo).items():
            tt = tp.trans_type
            if not tp.enabled or tt is None:
                continue
            if 1 <= tt <= 240 and self._sync_count % tt == 0:
                self._transmit(num, tp, values, time.monotonic())
            elif tt == 0 and self._changed(num, tp, values):
                self._transmit(num, tp, values, time.monotonic())

    def _values(self) -> dict[int, int]:
        with self.lock:
            return {
                0x6041: self.statusword(),
                0x606C: int(self.velocity),
                0x6064: int(self.position),
                0x6078: self.current_permille,
            }

    def _changed(self, num: int, tp: canopen.pdo.PdoMap, values: dict[int, int]) -> bool:
        return tuple(values.get(v.index) for v in tp) != self._tx_values.get(num)

    def _transmit(self, num: int, tp: canopen.pdo.PdoMap, values: dict[int, int], now: float) -> None:
        for var in tp:
            if var.index in values:
                var.raw = values[var.index]
        self._tx_values[num] = tuple(values.get(v.index) for v in tp)
        self._tx_last[num] = now
        tp.transmit()

    def _send_async(self, now: float) -> None:
        values = self._values()
        for num, tp in _maps(self.node.tpdo).items():
            tt = tp.trans_type
            if not tp.enabled or tt is None or tt < 254:
                continue
            timer = (tp.event_timer or 0) / 1000.0
            inhibit = (tp.inhibit_time or 0) / 10000.0
            last = self._tx_last.get(num, now)
            if timer > 0:  # periodic, and at once when the statusword (a device event) changes
                indices = [v.index for v in tp]
                before = self._tx_values.get(num)
                sw_changed = (
                    0x6041 in indices and before is not None and before[indices.index(0x6041)] != values[0x6041]
                )
                due = now - last >= timer or sw_changed
            else:
                due = self._changed(num, tp, values) and now - last >= inhibit
            if due:
                self._transmit(num, tp, values, now)

    # ------------------------------------------------------------------ heartbeat consumer

    def _on_host_heartbeat(self, can_id: int, data: bytearray, timestamp: float) -> None:
        self._host_seen = time.monotonic()

    def _watch_host(self, now: float) -> None:
        """CiA 301 heartbeat consumer: fault (EMCY 0x8130) when the watched producer goes silent."""
        if not self._obj(0x1016):
            return
        raw = int.from_bytes(self.node.data_store.get(0x1016, {}).get(1, b"\0\0\0\0"), "little")
        node, limit_ms = (raw >> 16) & 0xFF, raw & 0xFFFF
        active = raw if node and limit_ms and node <= 127 else 0
        if active != self._watched:
            if self._watched:
                self._network.unsubscribe(0x700 + ((self._watched >> 16) & 0x7F), self._on_host_heartbeat)
            self._watched, self._host_seen = active, None  # monitoring starts with the next heartbeat
            if active:
                self._network.subscribe(0x700 + node, self._on_host_heartbeat)
        if active and self._host_seen is not None and now - self._host_seen > limit_ms / 1000.0:
            self._host_seen = None  # one event per loss; monitoring restarts with the next heartbeat
            if self.machine.cia_state not in (State.FAULT, State.FAULT_REACTION_ACTIVE):
                self.fault(0x8130)
            if self.node.nmt.state == "OPERATIONAL":
                self.node.nmt.state = "PRE-OPERATIONAL"  # 0x1029 default: communication error -> pre-operational

    # ------------------------------------------------------------------ faults, state

    def fault(self, code: int, persist: bool = False) -> None:
        """Raise a drive fault: the EMCY goes out first, then the state changes.

        A drive's error handler sends its EMCY at the fault event, while the
        statusword TPDO follows at the next PDO cycle (and on a shared bus EMCY
        0x80+n wins arbitration over TPDO1 0x180+n): the host sees the code
        before the FAULT state. Holding the lock across both keeps this
        simulator's PDO thread from slipping the new statusword in between."""
        with self.lock:
            self.error_code = code
            self.error_register = _register_bits(code)
            self.fault_persists = persist
            if self._obj(0x1003):
                n = int.from_bytes(self.node.data_store.get(0x1003, {}).get(0, b"\0"), "little")
                self.node.data_store.setdefault(0x1003, {})[0] = bytes([min(n + 1, 1)])
                self.node.data_store[0x1003][1] = code.to_bytes(4, "little")
            self.node.emcy.send(code, self.error_register)
            self.machine.raise_fault()

    def statusword(self) -> int:
        return self.machine.statusword

    def step(self, now: float) -> None:
        if self.machine.cia_state == State.NOT_READY_TO_SWITCH_ON and now - self.booted_at >= BOOT_TRANSIENT:
            self.machine.boot()
        self._watch_host(now)
        nmt = self.node.nmt.state
        if nmt != self._last_nmt:
            self._last_nmt = nmt
            self.pdo_ready = False
            if nmt == "OPERATIONAL":
                self._load_pdo_config()
        with self.lock:
            st = self.machine.cia_state
            if st == State.FAULT_REACTION_ACTIVE:
                self.machine.fault_reaction_done()
                st = self.machine.cia_state
            if st == State.OPERATION_ENABLED:
                target, accel = float(self.target_velocity), self._param(0x6083, 10000)
            else:
                target, accel = 0.0, self._param(0x6085, 50000)
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
            self.current_permille = (
                int(min(1000.0, 50.0 + abs(self.velocity) * 0.05 + load)) if st == State.OPERATION_ENABLED else 0
            )
        if self.pdo_ready and nmt == "OPERATIONAL":
            self._send_async(now)

    def _param(self, index: int, default: float) -> float:
        return float(_raw(self.node, index)) if self._obj(index) else default

    def _load_pdo_config(self) -> None:
        """Read the PDO set-up the host wrote over SDO (NMT start)."""
        self.node.tpdo.read()
        self.node.rpdo.read()
        for rp in _maps(self.node.rpdo).values():
            if self._on_rpdo not in rp.callbacks:
                rp.add_callback(self._on_rpdo)
        # nothing is sent on entering OPERATIONAL: timers start now, changes count from here
        values, now = self._values(), time.monotonic()
        tpdos = _maps(self.node.tpdo)
        self._tx_last = dict.fromkeys(tpdos, now)
        self._tx_values = {num: tuple(values.get(v.index) for v in tp) for num, tp in tpdos.items()}
        self.pdo_ready = True

    def set_silenced(self, silenced: bool) -> None:
        self.silenced = silenced
        if silenced:
            self.node.nmt.stop_heartbeat()
        else:
            self.node.nmt.start_heartbeat(int(_raw(self.node, 0x1017)))


def _maps(pdos: PdoBase) -> PdoMaps:
    """The PDOs of one side of the node (canopen builds them with the node)."""
    if pdos.map is None:
        raise RuntimeError("the node has no PDO table")
    return pdos.map


def _raw(node: canopen.LocalNode, index: int) -> int | float | str | bytes:
    """The value of the node's own object ``index`` (a variable, not an array or record)."""
    var = node.sdo[index]
    if not isinstance(var, SdoVariable):
        raise TypeError(f"0x{index:04X} is not a variable")
    return var.raw


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
            node.fault(int(msg.get("code", 0x1000)), bool(msg.get("persist", False)))
        elif cmd == "clear":
            node.fault_persists = False
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
        d.node.nmt.send_command(0x80)  # -> PRE-OPERATIONAL (heartbeat only once 0x1017 is set)
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
