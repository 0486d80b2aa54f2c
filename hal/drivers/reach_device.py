"""One Reach device (a joint or the jaw) as this computer knows it: its latest
readings, mode, hardware status flags and limits, kept from the packets the
link's reader thread hands over, and the requests that keep them coming.

Readings stream as the device's heartbeat (POSITION, VELOCITY, CURRENT at
``feedback_rate_hz``, asked for with HEARTBEAT_SET and HEARTBEAT_FREQUENCY); the
mode and the hardware status flags are asked for with REQUEST every status
period; the limits once at connect (again until they arrive).
"""

from __future__ import annotations

import math
import struct
import threading
import time
from dataclasses import dataclass, field

from hal.drivers.reach_link import ReachLink
from hal.drivers.reach_protocol import HEARTBEAT_SLOTS, Mode, Packet, PacketId, encode, encode_request, mode_name

#: Packets each device streams as its heartbeat.
STREAMED = (PacketId.POSITION, PacketId.VELOCITY, PacketId.CURRENT)
#: Packets asked for every status period.
STATUS = (PacketId.MODE, PacketId.HARDWARE_STATUS)
#: Limits asked for at connect: (maximum, minimum) each.
LIMITS = (PacketId.POSITION_LIMITS, PacketId.VELOCITY_LIMITS, PacketId.CURRENT_LIMITS)


@dataclass
class DeviceState:
    """Latest values; times (s, backend clock) of arrival, None = never received."""

    position: float = math.nan
    velocity: float = math.nan
    current_ma: float = math.nan
    position_t: float | None = None
    velocity_t: float | None = None
    current_t: float | None = None
    mode: int | None = None
    mode_t: float | None = None
    flags: int | None = None
    flags_t: float | None = None
    limits: dict[int, tuple[float, float]] = field(default_factory=dict)  # packet id -> (min, max)


class ReachDevice:
    """One device id on a :class:`ReachLink`; ``name`` and ``where`` for messages."""

    def __init__(self, link: ReachLink, device_id: int, name: str) -> None:
        self.link = link
        self.device_id = device_id
        self.name = name
        self._lock = threading.Lock()
        self.state = DeviceState()
        self.mode_changes = threading.Condition(self._lock)
        self.malformed = 0

    # ------------------------------------------------------------------ from the reader thread
    def on_packet(self, p: Packet, t: float) -> None:
        pid = p.packet_id
        try:
            if pid in (PacketId.POSITION, PacketId.VELOCITY, PacketId.CURRENT):
                (value,) = p.floats()
                if not math.isfinite(value):
                    raise ValueError("non-finite")
                with self._lock:
                    s = self.state
                    if pid == PacketId.POSITION:
                        s.position, s.position_t = value, t
                    elif pid == PacketId.VELOCITY:
                        s.velocity, s.velocity_t = value, t
                    else:
                        s.current_ma, s.current_t = value, t
            elif pid == PacketId.MODE and len(p.data) == 1:
                with self._lock:
                    self.state.mode, self.state.mode_t = p.data[0], t
                    self.mode_changes.notify_all()
            elif pid == PacketId.HARDWARE_STATUS and p.data:
                flags = int.from_bytes(p.data[:4], "little")
                with self._lock:
                    self.state.flags, self.state.flags_t = flags, t
            elif pid in LIMITS:
                hi, lo = p.floats()
                with self._lock:
                    self.state.limits[pid] = (lo, hi)
        except ValueError:
            self.malformed += 1  # a packet of the wrong size or value: counted, skipped

    # ------------------------------------------------------------------ requests
    def heartbeat_setup(self, rate_hz: int) -> bytes:
        ids = bytes(STREAMED) + bytes(HEARTBEAT_SLOTS - len(STREAMED))
        return encode(self.device_id, PacketId.HEARTBEAT_SET, ids) + encode(
            self.device_id, PacketId.HEARTBEAT_FREQUENCY, bytes((rate_hz,))
        )

    def request_status(self) -> bytes:
        return encode_request(self.device_id, STATUS)

    def request_limits(self) -> bytes:
        return encode_request(self.device_id, LIMITS)

    def mode_frame(self, mode: Mode) -> bytes:
        return encode(self.device_id, PacketId.MODE, bytes((mode,)))

    def velocity_frame(self, value: float) -> bytes:
        return encode(self.device_id, PacketId.VELOCITY, struct.pack("<f", value))

    # ------------------------------------------------------------------ reading
    def snapshot(self) -> DeviceState:
        with self._lock:
            s = self.state
            return DeviceState(**{**s.__dict__, "limits": dict(s.limits)})

    def wait_mode(self, wanted: Mode, timeout: float, ask_every: float = 0.05) -> int | None:
        """Ask for the mode until the device reads ``wanted`` (returns it) or ``timeout`` s
        pass (returns the last mode read, None if none)."""
        deadline = time.monotonic() + timeout
        with self._lock:
            self.state.mode_t = None  # only a mode read from now on counts
        while True:
            self.link.post(encode_request(self.device_id, (PacketId.MODE,)))
            with self._lock:
                self.mode_changes.wait(min(ask_every, max(0.0, deadline - time.monotonic())))
                mode = self.state.mode if self.state.mode_t is not None else None
            if mode == wanted or time.monotonic() >= deadline:
                return mode

    def describe_mode(self) -> str:
        m = self.state.mode
        return "unknown" if m is None else mode_name(m)
