"""Water Linked DVL A50 driver: body velocity and altitude.

Two transports, one line-based protocol family:

* TCP (default port 16171): one JSON object per line; velocity reports have
  ``"type": "velocity"`` with ``vx, vy, vz`` (m/s, DVL frame), ``fom``,
  ``altitude`` (m), ``velocity_valid``, ``status``, ``time_of_validity`` (µs);
  dead-reckoning reports (``"type": "position_local"``) are ignored.
* Serial (115200 8N1): ``wrz,vx,vy,vz,valid(y/n),altitude,fom,cov(9 values
  separated by ';'),time_of_validity,time_of_transmission,time,status*cc``
  where ``cc`` is the CRC-8 (polynomial 0x07, init 0, no reflection, two
  lowercase hex digits) of everything before ``*``.

Each accepted report is stamped with the backend clock on arrival. Lines that
fail the checksum, do not parse, or carry absurd values (non-finite, speed above
``MAX_SPEED``) are counted and rejected, never used. With the vehicle's limits
(``vehicle_max_speed`` m/s, ``vehicle_max_acceleration`` m/s^2, from the HAL
config), reports the vehicle cannot produce are rejected too ("implausible"):
a speed above ``SPEED_MARGIN`` times the max speed plus ``SPEED_ALLOWANCE``
(water currents), or a change from the last accepted velocity above
``SPEED_MARGIN`` times the max acceleration times the time between them plus
``ACCEL_ALLOWANCE`` (the DVL's own noise). A DVL that keeps sending such
reports has no accepted velocity: it goes stale (FAULT) like a silent one; a DVL that has sent
nothing at all since the start is MISSING (not heard). A broken TCP connection or
a vanished serial port is reported and re-opened every ``REOPEN_PERIOD``.

The DVL frame is taken as the vehicle frame rotated by ``mounting_rpy``; the
lever-arm term (angular rate x offset) is not compensated.
"""

from __future__ import annotations

import json
import logging
import math
import socket
import threading
from collections.abc import Callable
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np
import serial

from hal.drivers.realtime import STEP_GATE, rate_of
from hal.interfaces import Health, HealthState
from kcl.rotations import rpy_to_matrix

log = logging.getLogger(__name__)

MAX_SPEED = 10.0  # m/s, anything faster is a corrupt report
#: Plausibility against the vehicle's configured limits (see the module docstring).
SPEED_MARGIN = 2.0
SPEED_ALLOWANCE = 0.25  # m/s
ACCEL_ALLOWANCE = 0.1  # m/s
MAX_ALTITUDE = 200.0  # m, beyond the A50's range
REOPEN_PERIOD = 0.5  # s
RECENT_REJECT_WINDOW = 2.0  # s, rejected lines this recent make the health DEGRADED
DVL_TCP_PORT = 16171


class DvlParseError(ValueError):
    """A DVL line that must not be used; ``kind`` is "crc", "format" or "absurd"."""

    def __init__(self, kind: str, message: str) -> None:
        super().__init__(message)
        self.kind = kind


@dataclass(frozen=True)
class DvlReport:
    """One velocity report in the DVL frame: velocity (3,) m/s or None when the
    DVL flagged it invalid (no bottom lock); altitude m or None; fom m/s."""

    velocity: np.ndarray | None
    altitude: float | None
    fom: float
    status: int


def _crc8_table() -> tuple[int, ...]:
    table = []
    for byte in range(256):
        crc = byte
        for _ in range(8):
            crc = ((crc << 1) ^ 0x07) & 0xFF if crc & 0x80 else (crc << 1) & 0xFF
        table.append(crc)
    return tuple(table)


_CRC8_TABLE = _crc8_table()


def crc8(data: bytes) -> int:
    """CRC-8, polynomial 0x07, init 0x00, no reflection, no final xor (table-driven)."""
    crc = 0
    for byte in data:
        crc = _CRC8_TABLE[crc ^ byte]
    return crc


def _checked(vx: float, vy: float, vz: float, valid: bool, altitude: float, fom: float, status: int) -> DvlReport:
    vel = np.array([vx, vy, vz], dtype=float)
    if not np.all(np.isfinite(vel)) or not math.isfinite(altitude) or not math.isfinite(fom):
        raise DvlParseError("absurd", "non-finite value")
    if valid and float(np.linalg.norm(vel)) > MAX_SPEED:
        raise DvlParseError("absurd", f"speed {np.linalg.norm(vel):.1f} m/s above {MAX_SPEED} m/s")
    if altitude > MAX_ALTITUDE:
        raise DvlParseError("absurd", f"altitude {altitude} m above {MAX_ALTITUDE} m")
    alt = altitude if altitude > 0 else None  # the A50 reports -1 without a bottom
    return DvlReport(vel if valid else None, alt, fom, status)


def parse_json_line(line: str) -> DvlReport | None:
    """Parse one TCP JSON line; None for reports that are not velocity reports."""
    try:
        msg = json.loads(line)
    except json.JSONDecodeError as exc:
        raise DvlParseError("format", f"broken JSON: {exc.msg}") from None
    if not isinstance(msg, dict):
        raise DvlParseError("format", "JSON line is not an object")
    if msg.get("type") != "velocity":
        return None
    try:
        return _checked(
            float(msg["vx"]),
            float(msg["vy"]),
            float(msg["vz"]),
            bool(msg["velocity_valid"]),
            float(msg.get("altitude", -1.0)),
            float(msg.get("fom", 0.0)),
            int(msg.get("status", 0)),
        )
    except (KeyError, TypeError, ValueError, OverflowError) as exc:
        if isinstance(exc, DvlParseError):
            raise
        raise DvlParseError("format", f"velocity report field missing or not a number: {exc}") from None


def parse_wrz_line(line: str) -> DvlReport | None:
    """Parse one serial line; None for other (non-``wrz``) sentences."""
    line = line.strip()
    if not line.startswith("wrz"):
        return None
    body, star, cs = line.rpartition("*")
    if not star or len(cs) != 2:
        raise DvlParseError("format", "missing checksum")
    if cs.strip("0123456789abcdef"):  # the A50 sends two lowercase hex digits; int() would also take "0D", "+d"
        raise DvlParseError("format", f"bad checksum field {cs!r} (two lowercase hex digits)")
    expected = int(cs, 16)
    got = crc8(body.encode("ascii", errors="replace"))
    if got != expected:
        raise DvlParseError("crc", f"CRC-8 mismatch (line says {expected:02x}, computed {got:02x})")
    parts = body.split(",")
    if len(parts) != 12:
        raise DvlParseError("format", f"wrz needs 11 fields, got {len(parts) - 1}")
    try:
        vx, vy, vz = (float(p) for p in parts[1:4])
        valid = parts[4] == "y"
        altitude, fom = float(parts[5]), float(parts[6])
        status = int(parts[11])
    except ValueError as exc:
        raise DvlParseError("format", f"field is not a number: {exc}") from None
    return _checked(vx, vy, vz, valid, altitude, fom, status)


def format_wrz(
    vx: float,
    vy: float,
    vz: float,
    valid: bool,
    altitude: float,
    fom: float = 0.002,
    status: int = 0,
    time_of_validity: int = 0,
    time_of_transmission: int = 0,
    dt_ms: float = 100.0,
) -> str:
    """A ``wrz`` line with its CRC (for simulators and tests)."""
    cov = ";".join(["0.000001"] * 9)
    body = f"wrz,{vx:.3f},{vy:.3f},{vz:.3f},{'y' if valid else 'n'},{altitude:.2f},{fom:.3f},{cov},{time_of_validity},{time_of_transmission},{dt_ms:.2f},{status}"
    return f"{body}*{crc8(body.encode()):02x}"


def rpy_matrix(rpy: tuple[float, float, float]) -> np.ndarray:
    """Rotation matrix (3x3) of Z-Y-X roll, pitch, yaw (rad): the project's one
    definition, :func:`kcl.rotations.rpy_to_matrix`."""
    return rpy_to_matrix(*rpy)


class LineSource:
    """Yields text lines from TCP or serial; raises OSError when the link breaks."""

    def __init__(
        self,
        transport: str,
        *,
        host: str = "",
        port: int = DVL_TCP_PORT,
        device: str | None = None,
        baudrate: int = 115200,
    ) -> None:
        self.transport, self.host, self.port, self.device, self.baudrate = transport, host, port, device, baudrate
        self._sock: socket.socket | None = None
        self._serial: serial.Serial | None = None
        self._buf = b""

    @property
    def where(self) -> str:
        return f"{self.host}:{self.port}" if self.transport == "tcp" else str(self.device)

    def open(self) -> None:
        if self.transport == "tcp":
            self._sock = socket.create_connection((self.host, self.port), timeout=1.0)
            self._sock.settimeout(0.2)
        else:
            try:
                self._serial = serial.Serial(self.device, self.baudrate, timeout=0.2)
            except serial.SerialException as exc:
                raise OSError(str(exc)) from exc
        self._buf = b""

    def close(self) -> None:
        for h in (self._sock, self._serial):
            if h is not None:
                try:
                    h.close()
                except Exception:  # noqa: BLE001
                    pass
        self._sock = self._serial = None

    def read_lines(self) -> list[str]:
        """Complete lines received so far (may be empty). OSError if the link is gone."""
        if self.transport == "tcp":
            if self._sock is None:
                raise OSError("the DVL link is not open")
            try:
                chunk = self._sock.recv(4096)
            except TimeoutError:
                return []
            if not chunk:
                raise OSError("connection closed by the DVL")
        else:
            if self._serial is None:
                raise OSError("the DVL link is not open")
            try:
                chunk = self._serial.read(self._serial.in_waiting or 1)
            except (serial.SerialException, OSError, TypeError) as exc:
                raise OSError(f"serial port lost: {exc}") from exc
        self._buf += chunk
        *lines, self._buf = self._buf.split(b"\n")
        if len(self._buf) > 65536:
            self._buf = b""  # garbage without newlines
        return [ln.decode("ascii", errors="replace").strip("\r") for ln in lines if ln.strip()]


class Rejection(NamedTuple):
    """The last line the driver rejected: when (backend clock, s) and why."""

    t: float
    why: str


class WaterLinkedDvl:
    """Background reader of one DVL. ``params``: the validated ``dvl`` config mapping."""

    name = "dvl"

    def __init__(
        self,
        params: dict,
        clock: Callable[[], float],
        mounting_rpy: tuple[float, float, float] = (0.0, 0.0, 0.0),
        vehicle_max_speed: float | None = None,
        vehicle_max_acceleration: float | None = None,
    ) -> None:
        self._clock = clock
        #: Plausible speed (m/s) and acceleration (m/s^2) limits, None: only the absurd-value check.
        self.speed_limit = None if vehicle_max_speed is None else SPEED_MARGIN * vehicle_max_speed + SPEED_ALLOWANCE
        self.accel_limit = None if vehicle_max_acceleration is None else SPEED_MARGIN * vehicle_max_acceleration
        self.timeout = params.get("timeout", 0.5)
        transport = params.get("transport", "tcp")
        self.source = LineSource(
            transport,
            host=params.get("host", ""),
            port=params.get("port", DVL_TCP_PORT),
            device=params.get("device"),
            baudrate=params.get("baudrate", 115200),
        )
        self._parse = parse_json_line if transport == "tcp" else parse_wrz_line
        self._R = rpy_matrix(mounting_rpy)
        self._lock = threading.Lock()
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None
        self._velocity: np.ndarray | None = None
        self._velocity_t: float | None = None
        self._altitude: float | None = None
        self._altitude_t: float | None = None
        self._any_t: float | None = None
        #: Any line received since the start, rejected ones too (never: the DVL is missing).
        self._heard = False
        self._invalid_since: float | None = None
        self.rejected: dict[str, int] = {"crc": 0, "format": 0, "absurd": 0, "implausible": 0}
        self._last_reject: Rejection | None = None
        self._link_error: str | None = None
        self._meter_times: list[float] = []

    def connect(self) -> None:
        self._stop.clear()
        self._thread = threading.Thread(target=self._run, name="dvl-reader", daemon=True)
        self._thread.start()

    def close(self) -> None:
        self._stop.set()
        if self._thread is not None:
            self._thread.join(timeout=1.0)
        self.source.close()

    def _run(self) -> None:
        opened = False
        while not self._stop.is_set():
            if not opened:
                try:
                    self.source.open()
                    opened = True
                    with self._lock:
                        self._link_error = None
                except OSError as exc:
                    with self._lock:
                        self._link_error = f"cannot open {self.source.where}: {exc}"
                    self._stop.wait(REOPEN_PERIOD)
                    continue
            try:
                lines = self.source.read_lines()
            except OSError as exc:
                with self._lock:
                    self._link_error = f"link to {self.source.where} lost: {exc}"
                self.source.close()
                opened = False
                self._stop.wait(REOPEN_PERIOD)
                continue
            arrived = None
            if lines:
                arrived = self._clock()  # stamped on arrival: the gate's wait counts as latency
                STEP_GATE.wait()  # decode after the control loop's step, not during it
            for line in lines:
                self.feed(line, arrived)

    def feed(self, line: str, arrived: float | None = None) -> None:
        """Handle one received line (public for tests and replay); ``arrived`` (s, the driver's
        clock) stamps it, default now."""
        now = self._clock() if arrived is None else arrived
        self._heard = True
        try:
            rep = self._parse(line)
        except DvlParseError as exc:
            with self._lock:
                self.rejected[exc.kind] += 1
                self._last_reject = Rejection(now, f"{exc.kind}: {exc}")
            return
        if rep is None:
            return
        why = self._implausible(rep.velocity, now)
        if why:
            with self._lock:
                self.rejected["implausible"] += 1
                self._last_reject = Rejection(now, f"implausible: {why}")
            return
        with self._lock:
            self._any_t = now
            self._meter_times = [t for t in self._meter_times if t > now - 2.0] + [now]
            if rep.velocity is not None:
                self._velocity, self._velocity_t, self._invalid_since = self._R @ rep.velocity, now, None
            elif self._invalid_since is None:
                self._invalid_since = now
            if rep.altitude is not None:
                self._altitude, self._altitude_t = rep.altitude, now

    def _implausible(self, v: np.ndarray | None, now: float) -> str | None:
        """Why a velocity (DVL frame, m/s) cannot be the vehicle's, or None."""
        if v is None:
            return None
        speed = float(np.linalg.norm(v))
        if self.speed_limit is not None and speed > self.speed_limit:
            return f"speed {speed:.2f} m/s above the vehicle's plausible {self.speed_limit:.2f} m/s"
        with self._lock:
            last, t_last = self._velocity, self._velocity_t
        if self.accel_limit is not None and last is not None and t_last is not None:
            dv = float(np.linalg.norm(self._R @ v - last))
            allowed = self.accel_limit * max(0.0, now - t_last) + ACCEL_ALLOWANCE
            if dv > allowed:
                return f"velocity jumped {dv:.2f} m/s in {now - t_last:.2f} s (plausible {allowed:.2f} m/s)"
        return None

    def velocity(self) -> tuple[np.ndarray | None, float | None]:
        """Latest valid body-frame velocity (3,) m/s and its time (s)."""
        with self._lock:
            return (None if self._velocity is None else self._velocity.copy()), self._velocity_t

    def altitude(self) -> tuple[float | None, float | None]:
        with self._lock:
            return self._altitude, self._altitude_t

    def health(self) -> Health:
        now = self._clock()
        with self._lock:
            rate = rate_of([t for t in self._meter_times if t > now - 2.0])
            info = {"where": self.source.where, "rate_hz": rate, "rejected": dict(self.rejected)}
            if self._link_error and (self._any_t is None or now - self._any_t > self.timeout):
                state = HealthState.FAULT if self._heard else HealthState.MISSING
                return Health(state, now, f"DVL: {self._link_error}", info)
            if self._velocity_t is None or now - self._velocity_t > self.timeout:
                if self._any_t is not None and now - self._any_t <= self.timeout and self._invalid_since is not None:
                    why = "no bottom lock (reports flagged invalid)"
                elif self._velocity_t is None and self._any_t is None:
                    why = "no velocity report received"
                else:
                    age = now - (self._velocity_t if self._velocity_t is not None else self._any_t or 0.0)
                    why = f"stale velocity ({age:.2f} s old, limit {self.timeout:.2f} s)"
                if self._last_reject and now - self._last_reject.t < RECENT_REJECT_WINDOW:
                    why += f"; last rejected line: {self._last_reject.why}"
                state = HealthState.FAULT if self._heard else HealthState.MISSING  # never heard: missing
                return Health(state, now, f"DVL: {why}", info)
            if self._last_reject and now - self._last_reject.t < RECENT_REJECT_WINDOW:
                return Health(HealthState.DEGRADED, now, f"DVL: rejected lines ({self._last_reject.why})", info)
            return Health(HealthState.OK, now, "", info)
