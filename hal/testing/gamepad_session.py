"""Operator sessions on an Xbox 360 pad as the kernel reports them (evemu recordings).

:func:`session` turns a list of :class:`Hold` (from time ``t``: these stick
deflections, these buttons held) into the event stream ``xpad`` and the input
core would give a reader: the pad reports every 8 ms (its USB interrupt
interval: ``bInterval`` 8 of the 360 pad's input endpoint), the input core passes
on only the values that changed (by more than the axis's fuzz), each packet
ends with ``SYN_REPORT``; sticks move to a new deflection over ``ramp_s`` as a
thumb does, buttons go down and up in one packet. Stick y axes are negative when
pushed up (``xpad`` reports them so). :func:`write_session` writes it as an
evemu file for the simulator (scenario ``operator.gamepad_recording``).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path

from hal.drivers.evemu import EvemuRecording, RawEvent, evemu_text
from hal.drivers.gamepad import (
    ABS_CODES,
    EV_ABS,
    EV_KEY,
    EV_SYN,
    KEY_CODES,
    SYN_REPORT,
    XBOX360_RANGES,
    rest_value,
)

#: s between the pad's reports (bInterval 8 ms of the Xbox 360 pad's interrupt endpoint)
REPORT_PERIOD_S = 0.008
PAD_NAME = "Microsoft X-Box 360 pad"


@dataclass(frozen=True)
class Hold:
    """From ``t`` (s): the sticks at ``axes`` (name -> fraction of full deflection,
    -1..1, y negative up) and the buttons in ``buttons`` held (names); axes not named
    at rest."""

    t: float
    axes: Mapping[str, float] = field(default_factory=dict)
    buttons: Sequence[str] = ()


def _raw(name: str, fraction: float) -> int:
    r = XBOX360_RANGES[ABS_CODES[name]]
    if r.minimum >= 0 and r.flat == 0:
        return int(round(r.minimum + fraction * (r.maximum - r.minimum)))
    centre = 0.5 * (r.minimum + r.maximum)
    half = 0.5 * (r.maximum - r.minimum)
    return int(max(r.minimum, min(r.maximum, round(centre + fraction * half))))


def session(holds: Sequence[Hold], end_s: float, ramp_s: float = 0.1) -> EvemuRecording:
    """The event stream of ``holds`` (in time order) until ``end_s`` (s)."""
    axes = {code: rest_value(r) for code, r in XBOX360_RANGES.items()}
    keys: set[int] = set()
    events: list[RawEvent] = []
    start_axes = dict(axes)
    target = dict(axes)
    hold_i = -1
    hold_t = 0.0
    n = int(end_s / REPORT_PERIOD_S)
    for i in range(n + 1):
        t = round(i * REPORT_PERIOD_S, 6)
        while hold_i + 1 < len(holds) and holds[hold_i + 1].t <= t:
            hold_i += 1
            h = holds[hold_i]
            hold_t = t
            start_axes = dict(axes)
            target = {code: rest_value(r) for code, r in XBOX360_RANGES.items()}
            for name, frac in h.axes.items():
                target[ABS_CODES[name]] = _raw(name, frac)
            wanted = {KEY_CODES[b] for b in h.buttons}
            packet = [RawEvent(t, EV_KEY, k, 1) for k in sorted(wanted - keys)]
            packet += [RawEvent(t, EV_KEY, k, 0) for k in sorted(keys - wanted)]
            keys = wanted
            if packet:
                events += packet + [RawEvent(t, EV_SYN, SYN_REPORT, 0)]
        frac = 1.0 if ramp_s <= 0 else min(1.0, (t - hold_t) / ramp_s)
        packet = []
        for code in sorted(axes):
            r = XBOX360_RANGES[code]
            value = int(round(start_axes[code] + frac * (target[code] - start_axes[code])))
            if abs(value - axes[code]) > r.fuzz or (value != axes[code] and value == target[code]):
                axes[code] = value
                packet.append(RawEvent(t, EV_ABS, code, value))
        if packet:
            events += packet + [RawEvent(t, EV_SYN, SYN_REPORT, 0)]
    return EvemuRecording(PAD_NAME, dict(XBOX360_RANGES), events)


def write_session(path: str | Path, holds: Sequence[Hold], end_s: float, ramp_s: float = 0.1) -> Path:
    """:func:`session` written to ``path`` as evemu text."""
    p = Path(path)
    p.write_text(evemu_text(session(holds, end_s, ramp_s)), encoding="utf-8")
    return p
