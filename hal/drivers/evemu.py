"""Recorded Linux input event streams in the text format of ``evemu-record``.

A recording of a real gamepad (``evemu-record /dev/input/eventN > pad.evemu``)
holds the device's description and then every event it sent, one per line::

    N: Microsoft X-Box 360 pad                 # the device's name
    A: 01 -32768 32767 16 128 0                # an axis: code (hex), min, max, fuzz, flat, resolution
    E: 0.250000 0003 0001 -32768               # an event: time (s), type (hex), code (hex), value
    E: 0.250000 0000 0000 0000                 # SYN_REPORT: the packet is complete

Other description lines (``I:``, ``P:``, ``B:``, ``L:``, ``S:``) and comments
(``#``, also after an event) are skipped. Event times are seconds from the
recording's start. :func:`read_evemu` reads one (a bad line is a
:class:`maris_common.yamlsrc.ConfigError` naming the file and line);
:func:`evemu_text` writes one. The simulator replays such a stream into
:class:`hal.drivers.gamepad.GamepadDecoder`, the decoding the real driver runs.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import NamedTuple

from maris_common.yamlsrc import ConfigError, ConfigIssue, Mark


class RawEvent(NamedTuple):
    """One ``struct input_event``: time (s), type, code, value (kernel ABI numbers)."""

    t: float
    type: int
    code: int
    value: int


class AbsRange(NamedTuple):
    """An absolute axis as the kernel describes it (``struct input_absinfo``): the
    value range, the noise filtered out (``fuzz``) and the dead zone around the
    centre (``flat``), in the device's units."""

    minimum: int
    maximum: int
    fuzz: int = 0
    flat: int = 0
    resolution: int = 0


@dataclass
class EvemuRecording:
    """A device's name, its absolute axes (code -> range) and its events in time order."""

    name: str = ""
    axes: dict[int, AbsRange] = field(default_factory=dict)
    events: list[RawEvent] = field(default_factory=list)


def read_evemu(path: str | Path) -> EvemuRecording:
    """The recording in ``path``; ConfigError (file:line) for a line it cannot read."""
    p = Path(path)
    try:
        text = p.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        raise ConfigError([ConfigIssue(Mark(str(p), 1, 1), (), f"cannot read the gamepad recording: {exc}")]) from None
    return parse_evemu(text, str(p))


def parse_evemu(text: str, file: str = "<recording>") -> EvemuRecording:
    """The recording in ``text`` (``file`` names it in errors); every bad line reported at once."""
    rec = EvemuRecording()
    issues: list[ConfigIssue] = []
    last_t = float("-inf")
    for number, raw in enumerate(text.splitlines(), start=1):
        line = raw.split("#", 1)[0].strip()
        if not line:
            continue
        tag, _, rest = line.partition(":")
        fields = rest.split()
        try:
            if tag == "N":
                rec.name = rest.strip()
            elif tag == "A":
                code, lo, hi, fuzz, flat = int(fields[0], 16), *(int(v) for v in fields[1:5])
                res = int(fields[5]) if len(fields) > 5 else 0
                if hi <= lo:
                    raise ValueError(f"axis {code:#04x}: maximum {hi} not above minimum {lo}")
                rec.axes[code] = AbsRange(lo, hi, fuzz, flat, res)
            elif tag == "E":
                t, etype, code, value = float(fields[0]), int(fields[1], 16), int(fields[2], 16), int(fields[3])
                if not t >= last_t:
                    raise ValueError(f"event time {t} before the previous event's {last_t}")
                last_t = t
                rec.events.append(RawEvent(t, etype, code, value))
            elif tag not in ("I", "P", "B", "L", "S"):
                raise ValueError(f"unknown line kind {tag!r}")
        except (ValueError, IndexError) as exc:
            why = str(exc) if isinstance(exc, ValueError) and str(exc) else "missing fields"
            issues.append(ConfigIssue(Mark(file, number, 1), (), f"evemu line `{raw.strip()}`: {why}"))
    if issues:
        raise ConfigError(issues)
    return rec


def evemu_text(rec: EvemuRecording) -> str:
    """``rec`` in the evemu text format (what :func:`parse_evemu` reads back)."""
    lines = ["# EVEMU 1.3", f"N: {rec.name}"]
    for code, r in sorted(rec.axes.items()):
        lines.append(f"A: {code:02x} {r.minimum} {r.maximum} {r.fuzz} {r.flat} {r.resolution}")
    for e in rec.events:
        lines.append(f"E: {e.t:.6f} {e.type:04x} {e.code:04x} {e.value:04d}")
    return "\n".join(lines) + "\n"
