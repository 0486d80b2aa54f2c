"""MicroStrain AHRS (3DM-GX3/-GX4/-GX5 family) over serial, MIP protocol.

MIP packet: ``0x75 0x65``, descriptor set (1 byte), payload length (1 byte),
payload = fields, then a 2-byte Fletcher-style checksum over everything before
it (sync bytes included): running sums ``a += byte; b += a`` modulo 256, sent
as ``a`` then ``b``. A field is ``length`` (1 byte, counting itself and the
descriptor), ``descriptor`` (1 byte), data. Floats are big-endian IEEE 754.

Used here: AHRS data set 0x80 fields 0x0C (Euler roll, pitch, yaw, rad),
0x05 (scaled gyro x, y, z, rad/s), 0x04 (scaled accelerometer, g). The device
must already stream them (set up once with the vendor tool or MIP commands);
this driver only listens. Angles are taken as the vehicle attitude after the
``mounting_rpy`` correction of the rates (sensor axes -> vehicle axes).
"""

from __future__ import annotations

import logging
import math
import struct
import threading
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import serial

from hal.drivers.dvl_waterlinked import REOPEN_PERIOD, rpy_matrix
from hal.drivers.realtime import STEP_GATE, rate_of
from hal.interfaces import Health, HealthState

log = logging.getLogger(__name__)

SYNC = b"\x75\x65"
AHRS_DATA_SET = 0x80
FIELD_ACCEL = 0x04
FIELD_GYRO = 0x05
FIELD_EULER = 0x0C
MAX_RATE = 20.0  # rad/s: faster is a corrupt packet


def mip_checksum(data: bytes) -> bytes:
    """The two MIP checksum bytes of ``data`` (header + payload)."""
    a = b = 0
    for byte in data:
        a = (a + byte) & 0xFF
        b = (b + a) & 0xFF
    return bytes((a, b))


def build_packet(descriptor_set: int, fields: list[tuple[int, bytes]]) -> bytes:
    """One MIP packet from (field descriptor, field data) pairs."""
    payload = b"".join(bytes((len(data) + 2, desc)) + data for desc, data in fields)
    head = SYNC + bytes((descriptor_set, len(payload))) + payload
    return head + mip_checksum(head)


def ahrs_packet(rpy: tuple[float, float, float], gyro: tuple[float, float, float]) -> bytes:
    """An AHRS data packet with Euler angles (rad) and scaled gyro (rad/s)."""
    return build_packet(
        AHRS_DATA_SET, [(FIELD_EULER, struct.pack(">3f", *rpy)), (FIELD_GYRO, struct.pack(">3f", *gyro))]
    )


@dataclass(frozen=True)
class MipPacket:
    descriptor_set: int
    fields: dict[int, bytes]


class MipParser:
    """Incremental MIP deframer: feed bytes, get packets; counts bad checksums and resyncs."""

    def __init__(self) -> None:
        self._buf = bytearray()
        self.bad_checksums = 0
        self.bad_fields = 0

    def feed(self, data: bytes) -> list[MipPacket]:
        self._buf += data
        out: list[MipPacket] = []
        while True:
            start = self._buf.find(SYNC)
            if start < 0:
                del self._buf[:-1]  # keep a possible first sync byte
                return out
            del self._buf[:start]
            if len(self._buf) < 4:
                return out
            n = self._buf[3]
            total = 4 + n + 2
            if len(self._buf) < total:
                return out
            pkt = bytes(self._buf[:total])
            if mip_checksum(pkt[:-2]) != pkt[-2:]:
                self.bad_checksums += 1
                del self._buf[:1]  # resync on the next sync pattern
                continue
            del self._buf[:total]
            fields = self._fields(pkt[4:-2])
            if fields is not None:
                out.append(MipPacket(pkt[2], fields))

    def _fields(self, payload: bytes) -> dict[int, bytes] | None:
        fields: dict[int, bytes] = {}
        i = 0
        while i < len(payload):
            ln = payload[i]
            if ln < 2 or i + ln > len(payload):
                self.bad_fields += 1
                return None
            fields[payload[i + 1]] = payload[i + 2 : i + ln]
            i += ln
        return fields


class MicrostrainAhrs:
    """Background reader of one AHRS on a serial port. ``params``: validated ``ahrs`` config."""

    name = "ahrs"

    def __init__(
        self, params: dict, clock: Callable[[], float], mounting_rpy: tuple[float, float, float] = (0.0, 0.0, 0.0)
    ) -> None:
        self._clock = clock
        self.device = params.get("device")
        self.baudrate = params.get("baudrate", 115200)
        self.timeout = params.get("timeout", 0.5)
        self._R = rpy_matrix(mounting_rpy)
        self.parser = MipParser()
        self._lock = threading.Lock()
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None
        self._serial: serial.Serial | None = None
        self._rpy: np.ndarray | None = None
        self._rates: np.ndarray | None = None
        self._t: float | None = None
        self._link_error: str | None = None
        self.rejected = 0
        self._times: list[float] = []

    def connect(self) -> None:
        self._stop.clear()
        self._thread = threading.Thread(target=self._run, name="ahrs-reader", daemon=True)
        self._thread.start()

    def close(self) -> None:
        self._stop.set()
        if self._thread is not None:
            self._thread.join(timeout=1.0)
        self._close_port()

    def _close_port(self) -> None:
        if self._serial is not None:
            try:
                self._serial.close()
            except Exception:  # noqa: BLE001
                pass
            self._serial = None

    def _run(self) -> None:
        while not self._stop.is_set():
            if self._serial is None:
                try:
                    self._serial = serial.Serial(self.device, self.baudrate, timeout=0.2)
                    with self._lock:
                        self._link_error = None
                except (serial.SerialException, OSError) as exc:
                    with self._lock:
                        self._link_error = f"cannot open {self.device}: {exc}"
                    self._stop.wait(REOPEN_PERIOD)
                    continue
            try:
                data = self._serial.read(self._serial.in_waiting or 1)
            except (serial.SerialException, OSError, TypeError) as exc:
                with self._lock:
                    self._link_error = f"serial port {self.device} lost: {exc}"
                self._close_port()
                self._stop.wait(REOPEN_PERIOD)
                continue
            if data:
                arrived = self._clock()  # stamped on arrival: the gate's wait counts as latency
                STEP_GATE.wait()  # decode after the control loop's step, not during it
                self.feed(data, arrived)

    def feed(self, data: bytes, arrived: float | None = None) -> None:
        """Handle received bytes (public for tests and replay); ``arrived`` (s, the driver's
        clock) stamps the readings, default now."""
        for pkt in self.parser.feed(data):
            if pkt.descriptor_set != AHRS_DATA_SET or FIELD_EULER not in pkt.fields:
                continue
            try:
                rpy = np.array(struct.unpack(">3f", pkt.fields[FIELD_EULER]))
                gyro = np.array(struct.unpack(">3f", pkt.fields[FIELD_GYRO])) if FIELD_GYRO in pkt.fields else None
            except struct.error:
                self.rejected += 1
                continue
            if (
                not np.all(np.isfinite(rpy))
                or np.any(np.abs(rpy) > 2 * math.pi)
                or (gyro is not None and (not np.all(np.isfinite(gyro)) or np.any(np.abs(gyro) > MAX_RATE)))
            ):
                self.rejected += 1
                continue
            now = self._clock() if arrived is None else arrived
            with self._lock:
                self._rpy = rpy
                self._rates = None if gyro is None else self._R @ gyro
                self._t = now
                self._times = [t for t in self._times if t > now - 2.0] + [now]

    def attitude(self) -> tuple[np.ndarray | None, np.ndarray | None, float | None]:
        """Latest (roll, pitch, yaw) rad, body rates (3,) rad/s or None, time (s)."""
        with self._lock:
            return (
                (None if self._rpy is None else self._rpy.copy()),
                (None if self._rates is None else self._rates.copy()),
                self._t,
            )

    def health(self) -> Health:
        now = self._clock()
        with self._lock:
            info = {
                "device": self.device,
                "rate_hz": rate_of([t for t in self._times if t > now - 2.0]),
                "bad_checksums": self.parser.bad_checksums,
                "rejected": self.rejected,
            }
            if self._t is None:
                # never heard since the start (whether or not its port opened): missing
                return Health(
                    HealthState.MISSING, now, f"AHRS: {self._link_error or 'no attitude packet received'}", info
                )
            if now - self._t > self.timeout:
                why = self._link_error or f"stale attitude ({now - self._t:.2f} s old, limit {self.timeout:.2f} s)"
                return Health(HealthState.FAULT, now, f"AHRS: {why}", info)
            return Health(HealthState.OK, now, "", info)
