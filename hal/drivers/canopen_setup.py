"""SDO set-up and release of one CiA 402 drive (blocking; called from
:meth:`hal.drivers.canopen_drive.Cia402Drive.configure` / ``release``).

Set-up, in NMT PRE-OPERATIONAL (where PDO mapping may change):

1. device type 0x1000 read back: the node must answer as a CiA 402 drive;
2. producer heartbeat 0x1017; consumer heartbeat 0x1016:1 watching the host
   (read back, so ``maris hal check`` shows the bound a crash of this computer
   leaves the drive running for), when the EDS has 0x1016;
3. profile velocity mode 0x6060 = 3, target velocity 0;
4. rated current 0x6075 if present, else ``rated_current_a`` from the config;
5. PDOs: if the mapping is writable, RPDO1 = controlword + target velocity,
   TPDO1 = statusword + velocity actual, TPDO2 = position actual (+ current
   actual), other PDOs disabled; if the file declares a fixed mapping, the
   drive's own mapping is read and must carry those objects. TPDO transmission
   (:data:`TRANSMISSIONS`): ``event_timer`` (255 + event timer = pdo_period),
   ``on_change`` (255 without timer: sent when a value changes), ``sync``
   (type 1: every SYNC, the host being the SYNC producer), ``auto`` = event
   timer when the EDS has sub-index 5, else sync when the bus has a SYNC
   period, else on change;
6. the current statusword, position, velocity (and, if faulted, the error code
   from 0x603F or 0x1003 and the error register 0x1001) read once over SDO,
   since on-change drives say nothing until something changes.

Release (clean close, drives already disabled): stop consuming our heartbeat
(0x1016:1 = 0) and NMT PRE-OPERATIONAL, so the drive does not fault when our
heartbeat stops and the next session can take it over.
"""

from __future__ import annotations

import functools
import logging
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import canopen
from canopen.pdo.base import PdoBase, PdoMaps

from hal.drivers.canopen_od import DRIVE_PROFILE, DriveOd

log = logging.getLogger(__name__)

PROFILE_VELOCITY_MODE = 3
PDO_NOT_VALID = 0x80000000
TRANSMISSIONS = ("auto", "event_timer", "on_change", "sync")
#: TPDO transmission types: asynchronous (event) and synchronous every SYNC.
TT_ASYNC, TT_SYNC = 255, 1


class DriveError(RuntimeError):
    """A drive could not be set up (no SDO answer, refused value, unusable EDS, ...)."""


@dataclass
class DriveSetup:
    """What the set-up found and chose."""

    transmission: str
    rated_current_a: float | None
    host_watch_s: float | None  # drive's consumer heartbeat time for our node, read back (None: not watched)
    device_type: int
    initial: dict[int, int]
    error_code: int | None = None
    error_register: int | None = None
    rpdos: list[Any] = field(default_factory=list)  # canopen PdoMaps carrying controlword / target velocity
    notes: list[str] = field(default_factory=list)


def resolve_transmission(requested: str, dod: DriveOd, sync_period: float | None) -> str:
    """The TPDO transmission mode to use (see the module docstring)."""
    if requested != "auto":
        return requested
    if dod.tpdo_event_timer:
        return "event_timer"
    return "sync" if sync_period else "on_change"


def _sdo(where: str, what: str, fn: Callable[[], Any]) -> Any:
    try:
        return fn()
    except canopen.SdoAbortedError as exc:
        raise DriveError(f"{where}: {what}: the drive refused it ({exc})") from None
    except canopen.SdoCommunicationError as exc:
        raise DriveError(f"{where}: {what}: no SDO answer ({exc}); is the drive powered and on this bus?") from None


def configure_drive(node: canopen.RemoteNode, dod: DriveOd, p: Any, where: str, on_tpdo: Callable) -> DriveSetup:
    """Steps 1-6 of the module docstring. ``p``: the drive's DriveParams. Raises DriveError."""
    od = dod.od
    node.nmt.send_command(0x80)  # PRE-OPERATIONAL: PDO mapping may only change there
    device_type = int(_sdo(where, "read device type 0x1000", lambda: node.sdo[0x1000].raw))
    if device_type & 0xFFFF != DRIVE_PROFILE:
        raise DriveError(
            f"{where}: answers as a CiA {device_type & 0xFFFF} device (0x1000 = 0x{device_type:08X}), "
            f"not a CiA {DRIVE_PROFILE} drive; wrong node ID or EDS {dod.path}?"
        )
    transmission = resolve_transmission(p.transmission, dod, p.sync_period)
    if transmission == "event_timer" and not dod.tpdo_event_timer:
        raise DriveError(
            f"{where}: transmission `event_timer` needs TPDO event timers (0x1800/0x1801 sub-index 5), "
            f"which EDS {dod.path} does not have; use `on_change` or `sync` (see docs/faults.md)"
        )
    if transmission == "sync" and not p.sync_period:
        raise DriveError(f"{where}: transmission `sync` needs a SYNC producer: set `sync_period` on the bus")
    setup = DriveSetup(transmission, None, None, device_type, {}, notes=list(dod.notes))
    _sdo(
        where,
        "set producer heartbeat 0x1017",
        lambda: setattr(node.sdo[0x1017], "raw", max(1, round(p.heartbeat_period * 1000))),
    )
    setup.host_watch_s = _watch_host(node, dod, p, where)
    if 0x1016 in dod.od and setup.host_watch_s is None:
        setup.notes.append(
            "host heartbeat watch is off (host_heartbeat_timeout: 0): the drive runs on if this computer dies"
        )
    elif setup.host_watch_s is not None and abs(setup.host_watch_s - p.host_heartbeat_timeout) > 0.0005:
        setup.notes.append(
            f"the drive holds a host heartbeat watch of {setup.host_watch_s:g} s, "
            f"not the configured {p.host_heartbeat_timeout:g} s"
        )
    _sdo(
        where, "set profile velocity mode (0x6060 = 3)", lambda: setattr(node.sdo[0x6060], "raw", PROFILE_VELOCITY_MODE)
    )
    _sdo(where, "zero the target velocity 0x60FF", lambda: setattr(node.sdo[0x60FF], "raw", 0))
    if 0x6075 in od:
        setup.rated_current_a = _sdo(where, "read rated current 0x6075", lambda: node.sdo[0x6075].raw) / 1000.0
    else:
        setup.rated_current_a = p.rated_current_a
    setup.rpdos = _sdo(where, "set up the RPDOs", lambda: _setup_rpdos(node, dod, where))
    _sdo(where, "set up the TPDOs", lambda: _setup_tpdos(node, dod, p, where, transmission, on_tpdo))
    mode = _sdo(where, "read the mode display 0x6061", lambda: node.sdo[0x6061].raw)
    if mode != PROFILE_VELOCITY_MODE:
        raise DriveError(f"{where}: drive reports mode {mode}, wanted profile velocity ({PROFILE_VELOCITY_MODE})")
    for index in (0x6041, 0x6064, 0x606C) + ((0x6078,) if 0x6078 in od else ()):
        setup.initial[index] = int(_sdo(where, f"read 0x{index:04X}", functools.partial(_read_raw, node, index)))
    if setup.initial[0x6041] & 0x4F == 0x08:  # FAULT: its description, since its EMCY went out before we listened
        setup.error_code, setup.error_register = read_fault(node, dod)
    return setup


def _watch_host(node: canopen.RemoteNode, dod: DriveOd, p: Any, where: str) -> float | None:
    """Write and read back 0x1016:1 (host node ID << 16 | ms); seconds watched, None if not."""
    if 0x1016 not in dod.od:
        return None
    value = (
        (p.host_node_id << 16) | min(0xFFFF, round(p.host_heartbeat_timeout * 1000))
        if p.host_heartbeat_timeout > 0
        else 0
    )
    _sdo(where, "set consumer heartbeat 0x1016:1", lambda: setattr(node.sdo[0x1016][1], "raw", value))
    back = int(_sdo(where, "read back 0x1016:1", lambda: node.sdo[0x1016][1].raw))
    if (back >> 16) & 0xFF != p.host_node_id or not back & 0xFFFF:
        return None
    return (back & 0xFFFF) / 1000.0


def read_fault(node: canopen.RemoteNode, dod: DriveOd) -> tuple[int | None, int | None]:
    """(error code, error register) read over SDO; None where unavailable."""
    code = register = None
    try:
        if 0x603F in dod.od:
            code = int(node.sdo[0x603F].raw)
        elif dod.has(0x1003, 1):
            code = int(node.sdo[0x1003][1].raw) & 0xFFFF
        register = int(node.sdo[0x1001].raw)
    except (canopen.SdoAbortedError, canopen.SdoCommunicationError) as exc:
        log.info("reading the fault of node %d failed: %s", node.id, exc)
    return code, register


def _read_raw(node: canopen.RemoteNode, index: int) -> Any:
    """The raw value of object ``index`` of ``node``, read over SDO."""
    return node.sdo[index].raw


def _maps(pdos: PdoBase, where: str) -> PdoMaps:
    """The PDOs of one side (RPDO or TPDO) of a node (canopen builds them with the node)."""
    if pdos.map is None:
        raise DriveError(f"{where}: the node has no PDO table")
    return pdos.map


def _node_id(node: canopen.RemoteNode, where: str) -> int:
    if node.id is None:
        raise DriveError(f"{where}: the node has no node ID")
    return node.id


def _disable_others(maps: PdoMaps, used: set[int]) -> None:
    """Invalidate PDOs we do not use (best effort: fewer frames on the bus)."""
    for num, pdo in maps.items():
        if num in used:
            continue
        try:
            cob = int(pdo.com_record[1].raw)
            if not cob & PDO_NOT_VALID and pdo.com_record[1].od.writable:
                pdo.com_record[1].raw = cob | PDO_NOT_VALID
        except (canopen.SdoAbortedError, canopen.SdoCommunicationError, KeyError) as exc:
            log.info("could not disable %s: %s", pdo.com_record.od.name, exc)


def _setup_rpdos(node: canopen.RemoteNode, dod: DriveOd, where: str) -> list[Any]:
    if dod.rpdos[0].mapping_writable and dod.rpdos[0].capacity >= 2:
        rp = node.rpdo[1]
        rp.clear()
        rp.cob_id = 0x200 + _node_id(node, where)
        rp.add_variable(0x6040)
        rp.add_variable(0x60FF)
        rp.trans_type = TT_ASYNC
        rp.enabled = True
        rp.save()
        _disable_others(_maps(node.rpdo, where), {1})
        return [rp]
    used = []
    for rp in _maps(node.rpdo, where).values():
        rp.read()
        if rp.enabled and {v.index for v in rp} & {0x6040, 0x60FF}:
            used.append(rp)
    covered = {v.index for rp in used for v in rp}
    missing = [f"0x{i:04X}" for i in (0x6040, 0x60FF) if i not in covered]
    if missing:
        raise DriveError(f"{where}: the drive's fixed RPDO mapping (EDS {dod.path}) carries no {', '.join(missing)}")
    return used


def _setup_tpdos(
    node: canopen.RemoteNode, dod: DriveOd, p: Any, where: str, transmission: str, on_tpdo: Callable
) -> None:
    tt = TT_SYNC if transmission == "sync" else TT_ASYNC
    event_ms = max(1, round(p.pdo_period * 1000)) if transmission == "event_timer" else 0
    wanted = [(0x6041, 0x606C), (0x6064,) + ((0x6078,) if 0x6078 in dod.od else ())]
    if all(t.mapping_writable and t.capacity >= len(w) for t, w in zip(dod.tpdos, wanted)):
        for num, objs in enumerate(wanted, start=1):
            tp = node.tpdo[num]
            tp.clear()
            tp.cob_id = 0x80 + 0x100 * num + _node_id(node, where)
            for obj in objs:
                tp.add_variable(obj)
            tp.trans_type = tt
            tp.event_timer = event_ms if 5 in dod.tpdos[num - 1].comm_subs else None
            tp.enabled = True
            tp.save()
            tp.add_callback(on_tpdo)
        _disable_others(_maps(node.tpdo, where), {1, 2})
        return
    needed = {0x6041, 0x606C, 0x6064}
    seen: set[int] = set()
    for num, tp in _maps(node.tpdo, where).items():
        tp.read()
        mapped = {v.index for v in tp}
        if not tp.enabled or not mapped & (needed | {0x6078}):
            continue
        tp.com_record[2].raw = tt
        if 5 in dod.tpdos[num - 1].comm_subs:
            tp.com_record[5].raw = event_ms
        tp.add_callback(on_tpdo)
        seen |= mapped
    missing = [f"0x{i:04X}" for i in sorted(needed - seen)]
    if missing:
        raise DriveError(f"{where}: the drive's fixed TPDO mapping (EDS {dod.path}) sends no {', '.join(missing)}")


def release_drive(node: canopen.RemoteNode, dod: DriveOd, where: str, alive: bool) -> None:
    """Clean close: stop watching our heartbeat, then NMT PRE-OPERATIONAL. Never raises."""
    if alive and 0x1016 in dod.od:
        try:
            node.sdo[0x1016][1].raw = 0
        except (canopen.SdoAbortedError, canopen.SdoCommunicationError) as exc:
            log.warning("%s: could not stop its heartbeat watch (0x1016): %s; it may fault when we stop", where, exc)
    try:
        node.nmt.send_command(0x80)
    except Exception as exc:  # noqa: BLE001 - closing goes on
        log.warning("%s: NMT pre-operational failed: %s", where, exc)
