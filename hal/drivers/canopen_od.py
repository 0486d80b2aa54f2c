"""A drive's object dictionary (EDS/DCF file): what the driver needs from it,
what it can do without, and clear errors for files it cannot use.

The driver's **required** objects are the CiA 301 identity/heartbeat basics and
the CiA 402 objects of profile velocity mode (:data:`REQUIRED`); without one of
them the drive cannot be run safely and :func:`load_drive_od` raises
:class:`EdsError` naming the device, the node and the file. Everything else is
**optional** (:data:`OPTIONAL`): the driver falls back where the file lacks it
and :attr:`DriveOd.notes` says what is missing, for ``maris hal check``:

* 0x1016 consumer heartbeat: the drive cannot watch this computer's heartbeat,
  so it does not stop by itself when the host dies;
* 0x6075 motor rated current: currents need ``rated_current_a`` from the HAL config;
* 0x6078 current actual value: no motor currents (NaN);
* 0x603F error code: fault descriptions come from EMCY / 0x1003 only;
* TPDO event timer (0x18xx sub-index 5): the drive cannot send periodically;
  it sends on change or on SYNC (see ``transmission`` in the HAL config).

Data types of the objects the driver reads or writes are checked against CiA
301/402 (a statusword declared as a string would only fail at run time).
"""

from __future__ import annotations

import logging
from dataclasses import dataclass, field
from pathlib import Path

import canopen
from canopen.objectdictionary import ODArray, ODRecord, ODVariable
from canopen.objectdictionary import datatypes as dt

log = logging.getLogger(__name__)

#: CiA 402 device profile number (low 16 bits of 0x1000).
DRIVE_PROFILE = 402

#: Objects the driver cannot work without: index -> (name, allowed data types).
REQUIRED: dict[int, tuple[str, tuple[int, ...]]] = {
    0x1000: ("device type", (dt.UNSIGNED32,)),
    0x1001: ("error register", (dt.UNSIGNED8,)),
    0x1017: ("producer heartbeat time", (dt.UNSIGNED16,)),
    0x6040: ("controlword", (dt.UNSIGNED16,)),
    0x6041: ("statusword", (dt.UNSIGNED16,)),
    0x6060: ("modes of operation", (dt.INTEGER8,)),
    0x6061: ("modes of operation display", (dt.INTEGER8,)),
    0x6064: ("position actual value", (dt.INTEGER32,)),
    0x606C: ("velocity actual value", (dt.INTEGER32,)),
    0x60FF: ("target velocity", (dt.INTEGER32,)),
}

#: Optional objects: index -> (name, allowed data types, what the driver does without it).
OPTIONAL: dict[int, tuple[str, tuple[int, ...], str]] = {
    0x1016: (
        "consumer heartbeat time",
        (dt.UNSIGNED32,),
        "the drive cannot watch this computer's heartbeat: it will NOT stop by itself if the host dies",
    ),
    0x6075: ("motor rated current", (dt.UNSIGNED32,), "currents in A need `rated_current_a` in the HAL config"),
    0x6078: ("current actual value", (dt.INTEGER16,), "no motor current readings"),
    0x603F: ("error code", (dt.UNSIGNED16,), "fault descriptions come from EMCY and 0x1003 only"),
    0x1003: ("pre-defined error field", (dt.UNSIGNED32,), "no error history"),
}

_TYPE_NAMES = {v: k for k, v in vars(dt).items() if k.isupper() and isinstance(v, int)}


class EdsError(RuntimeError):
    """An EDS/DCF file the driver cannot use; the message names device, node and file."""


@dataclass(frozen=True)
class PdoLayout:
    """One PDO communication/mapping pair as the file declares it."""

    number: int  # 1-based PDO number
    comm_subs: frozenset[int]  # sub-indices of the communication record present in the file
    mapping_writable: bool  # the mapping entries may be written (rw/wo/rww)
    capacity: int  # number of mapping entries


@dataclass
class DriveOd:
    """A loaded, checked object dictionary plus what it lacks."""

    od: canopen.ObjectDictionary
    path: str
    device_type: int | None
    present_optional: frozenset[int]
    tpdos: list[PdoLayout]
    rpdos: list[PdoLayout]
    notes: list[str] = field(default_factory=list)

    def has(self, index: int, sub: int | None = None) -> bool:
        obj = self.od.get(index)
        if obj is None:
            return False
        if sub is None or isinstance(obj, ODVariable):
            return sub in (None, 0)
        return sub in obj.subindices

    @property
    def tpdo_event_timer(self) -> bool:
        """True when the TPDOs the driver uses (1 and 2) have an event timer (sub-index 5)."""
        return len(self.tpdos) >= 2 and all(5 in t.comm_subs for t in self.tpdos[:2])


def _var(od: canopen.ObjectDictionary, index: int, sub: int = 0) -> ODVariable | None:
    obj = od.get(index)
    if isinstance(obj, ODVariable):
        return obj
    if isinstance(obj, (ODRecord, ODArray)):
        return obj.subindices.get(sub if sub else 1)
    return None


def _type_name(t: int | None) -> str:
    if t is None:
        return "no data type"
    return f"{_TYPE_NAMES.get(t, 'unknown type')} (0x{t:04X})"


def _pdo_layouts(od: canopen.ObjectDictionary, comm_base: int, map_base: int) -> list[PdoLayout]:
    out = []
    for k in range(512):
        comm, mapping = od.get(comm_base + k), od.get(map_base + k)
        if not isinstance(comm, (ODRecord, ODArray)) or not isinstance(mapping, (ODRecord, ODArray)):
            break
        entries = [v for s, v in mapping.subindices.items() if s >= 1]
        writable = bool(entries) and all(v.writable for v in entries)
        out.append(PdoLayout(k + 1, frozenset(comm.subindices), writable, len(entries)))
    return out


def load_drive_od(path: str | Path, node_id: int, where: str) -> DriveOd:
    """Read and check the EDS/DCF at ``path`` for the drive at ``node_id``.

    ``where`` names the device for messages (e.g. ``arm joint j2``). Raises
    :class:`EdsError` for unreadable files, files of non-drive devices, missing
    required objects and wrong data types (all problems at once)."""
    p = str(path)
    head = f"{where} (node {node_id}): EDS {p}"
    try:
        od = canopen.import_od(p, node_id)
    except Exception as exc:  # noqa: BLE001 - configparser, ValueError, UnicodeDecodeError, KeyError ...
        raise EdsError(f"{head}: not a readable EDS/DCF file ({type(exc).__name__}: {_short(exc)})") from None
    if not od.indices:
        raise EdsError(f"{head}: no objects found; is this an EDS file?")
    problems: list[str] = []
    device_type = None
    dtv = _var(od, 0x1000)
    if dtv is not None and isinstance(dtv.default, int):
        device_type = dtv.default
        if device_type & 0xFFFF != DRIVE_PROFILE:
            problems.append(
                f"describes a CiA {device_type & 0xFFFF} device (device type 0x{device_type:08X}), "
                f"not a CiA {DRIVE_PROFILE} drive"
            )
    missing = [f"0x{i:04X} {name}" for i, (name, _) in REQUIRED.items() if i not in od]
    if missing:
        problems.append("lacks required object(s) " + ", ".join(missing))
    for index, (name, types) in REQUIRED.items():
        problems += _type_problem(od, index, name, types)
    for index, (name, types, _) in OPTIONAL.items():
        problems += _type_problem(od, index, name, types)
    tpdos = _pdo_layouts(od, 0x1800, 0x1A00)
    rpdos = _pdo_layouts(od, 0x1400, 0x1600)
    if len(tpdos) < 2:
        problems.append(f"declares {len(tpdos)} TPDO(s) (0x1800/0x1A00 pairs); the driver needs 2")
    if not rpdos:
        problems.append("declares no RPDO (0x1400/0x1600 pair)")
    if problems:
        raise EdsError(f"{head}: " + "; ".join(problems))
    present = frozenset(i for i in OPTIONAL if i in od)
    notes = [
        f"EDS has no 0x{i:04X} ({name}): {without}"
        for i, (name, _types, without) in OPTIONAL.items()
        if i not in present and i != 0x1003
    ]
    result = DriveOd(od, p, device_type, present, tpdos, rpdos, notes)
    if not result.tpdo_event_timer:
        result.notes.append("EDS TPDOs have no event timer (sub-index 5): the drive sends on change or on SYNC")
    return result


def _type_problem(od: canopen.ObjectDictionary, index: int, name: str, types: tuple[int, ...]) -> list[str]:
    var = _var(od, index)
    if index not in od:
        return []
    if var is None:
        return [f"0x{index:04X} {name} has no usable entry"]
    if var.data_type not in types:
        want = " or ".join(_type_name(t) for t in types)
        # canopen reads a type the file does not define as DOMAIN (and logs a warning)
        got = "an undefined data type" if var.data_type == dt.DOMAIN else f"data type {_type_name(var.data_type)}"
        return [f"0x{index:04X} {name} has {got}, CiA 301/402 say {want}"]
    return []


def _short(exc: BaseException) -> str:
    text = str(exc).strip().splitlines()
    return (text[0] if text else "")[:200]
