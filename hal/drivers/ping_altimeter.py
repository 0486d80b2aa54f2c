"""Blue Robotics Ping echosounder (Ping1D) as an altimeter, through the
``bluerobotics-ping`` package (``brping.Ping1D``), serial or UDP.

The Ping sends nothing unasked (ping-protocol ``ping1d.json``: messages are
answers to a request, or the profile stream after ``continuous_start``); this
reader asks for ``distance`` (id 1212: distance mm, confidence %, ping number,
scan range) ``rate_hz`` times a second in its own thread (brping's requests
block up to 0.5 s each). A reading counts as an altitude when its confidence is
at least ``min_confidence`` %; a sonar whose ``ping_number`` stops advancing is
not measuring any more (pinging disabled, stalled firmware) and its readings
go stale. Altitude (m) = distance + ``offset_m`` (the transducer's height above
the altitude reference of the vehicle; negative below it).

Health: OK while confident measurements come; DEGRADED while it answers but is
not confident (no bottom in its range); MISSING until its first answer (not
heard since the start: the run's preflight refuses to start unless the operator
allows it, ``maris run --allow-missing ping``); FAULT once it has answered and
then goes silent, stops measuring or loses its link (lost). The vehicle keeps
working without it (its altitude falls back to ArduSub's rangefinder or is
unknown): the fault table's ``sensor_lost`` row for the vehicle's sensors
(``mission.runtime.safety.VEHICLE_SENSORS``) makes its loss a logged warning,
not a lost vehicle link.
"""

from __future__ import annotations

import contextlib
import io
import logging
import threading
import time
from collections.abc import Callable
from typing import Any

from hal.drivers.realtime import STEP_GATE, rate_of
from hal.drivers.setup_checks import check_stream_source
from hal.interfaces import Health, HealthState

log = logging.getLogger(__name__)

#: Time (s) between attempts to open or initialise a silent or broken sonar.
REOPEN_PERIOD = 1.0


class PingAltimeter:
    """Background reader of one Ping1D. ``params``: the validated ``ping`` config
    record; ``where``: its config entry (``file:line``) for set-up errors."""

    name = "ping"

    def __init__(self, params: dict[str, Any], clock: Callable[[], float], where: str = "ping") -> None:
        self.params = params
        self._clock = clock
        self.where = where
        self.timeout = float(params.get("timeout", 1.0))
        self.period = 1.0 / float(params.get("rate_hz", 10.0))
        self.min_confidence = int(params.get("min_confidence", 50))
        self.offset_m = float(params.get("offset_m", 0.0))
        transport = params.get("transport", "serial")
        self.address = (
            str(params.get("device")) if transport == "serial" else f"{params.get('host')}:{params.get('port')}"
        )
        self._lock = threading.Lock()
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None
        self._altitude: float | None = None
        self._altitude_t: float | None = None
        self._last: dict[str, Any] | None = None
        self._last_t: float | None = None
        self._ping_number: int | None = None
        self._ping_number_t: float | None = None
        self._answer_times: list[float] = []
        self.unanswered = 0
        self.link_error = ""
        self.device_info: str | None = None

    # ------------------------------------------------------------------ life cycle
    def check_setup(self) -> None:
        """Set-up errors now (serial device absent, host unresolvable): SetupError."""
        check_stream_source(self.params, self.where, "Ping echosounder")

    def connect(self) -> None:
        self.check_setup()
        self._stop.clear()
        self._thread = threading.Thread(target=self._run, name="ping-reader", daemon=True)
        self._thread.start()

    def close(self) -> None:
        self._stop.set()
        if self._thread is not None:
            self._thread.join(timeout=2.0)
            self._thread = None

    # ------------------------------------------------------------------ reader thread
    def _open(self) -> Any:
        from brping import Ping1D

        p = self.params
        sonar = Ping1D()
        with contextlib.redirect_stdout(io.StringIO()):  # brping prints on connect
            if p.get("transport", "serial") == "serial":
                sonar.connect_serial(p["device"], int(p.get("baudrate", 115200)))
            else:
                sonar.connect_udp(p["host"], int(p.get("port", 9090)))
        return sonar

    def _run(self) -> None:
        sonar: Any = None
        while not self._stop.is_set():
            if sonar is None:
                try:
                    sonar = self._open()
                    with contextlib.redirect_stdout(io.StringIO()):
                        ok = sonar.initialize()
                    if not ok:
                        raise OSError("no answer to the protocol-version request")
                    info = sonar.get_device_information()
                    if info:
                        self.device_info = "firmware {firmware_version_major}.{firmware_version_minor}".format(**info)
                    sos = self.params.get("speed_of_sound_mps")
                    if sos:
                        self._set_speed_of_sound(sonar, int(round(sos * 1000)))
                    self.link_error = ""
                except Exception as exc:  # noqa: BLE001 - brping raises plain Exception
                    self.link_error = f"{self.address}: {exc}"
                    self._close(sonar)
                    sonar = None
                    self._stop.wait(REOPEN_PERIOD)
                    continue
            t_ask = time.monotonic()
            STEP_GATE.wait()  # brping decodes inside the request: ask after the control loop's step
            try:
                with contextlib.redirect_stdout(io.StringIO()):
                    reading = sonar.get_distance()
            except Exception as exc:  # noqa: BLE001 - a serial port unplugged, a socket error
                self.link_error = f"{self.address} lost: {exc}"
                self._close(sonar)
                sonar = None
                self._stop.wait(REOPEN_PERIOD)
                continue
            now = self._clock()
            self.feed(reading, now)
            self._stop.wait(max(0.0, self.period - (time.monotonic() - t_ask)))
        self._close(sonar)

    @staticmethod
    def _set_speed_of_sound(sonar: Any, mm_s: int) -> None:
        """set_speed_of_sound (1002), read back (1203). Not brping's ``Ping1D.set_speed_of_sound``:
        in bluerobotics-ping 0.2.5 it fills the field ``speed_of_sound`` while its message
        definition names it ``sos_mm_per_sec``, so it sends 0 and fails reading the answer."""
        from brping import definitions, pingmessage

        msg = pingmessage.PingMessage(definitions.PING1D_SET_SPEED_OF_SOUND)
        field = msg.payload_field_names[0]
        setattr(msg, field, mm_s)
        msg.pack_msg_data()
        sonar.write(msg.msg_data)
        reply = sonar.request(definitions.PING1D_SPEED_OF_SOUND)
        got = getattr(reply, field, None) if reply is not None else None
        if got != mm_s:
            raise OSError(f"speed of sound {mm_s} mm/s not taken (the sonar reads {got})")

    @staticmethod
    def _close(sonar: Any) -> None:
        iodev = getattr(sonar, "iodev", None)
        if iodev is not None:
            try:
                iodev.close()
            except Exception:  # noqa: BLE001
                pass

    def feed(self, reading: dict[str, Any] | None, now: float) -> None:
        """One answer to a distance request (None: none came in time)."""
        with self._lock:
            if reading is None:
                self.unanswered += 1
                return
            self._answer_times = [t for t in self._answer_times if t > now - 2.0] + [now]
            self._last, self._last_t = reading, now
            number = int(reading.get("ping_number", -1))
            if number != self._ping_number:  # a new measurement
                self._ping_number, self._ping_number_t = number, now
                if int(reading.get("confidence", 0)) >= self.min_confidence:
                    self._altitude = float(reading["distance"]) / 1000.0 + self.offset_m
                    self._altitude_t = now

    # ------------------------------------------------------------------ readings
    def altitude(self) -> tuple[float | None, float | None]:
        """Latest confident altitude (m) and its time (s), or (None, None) if none."""
        with self._lock:
            return self._altitude, self._altitude_t

    def health(self) -> Health:
        now = self._clock()
        with self._lock:
            last = self._last
            info: dict[str, Any] = {
                "where": self.address,
                "answers_hz": rate_of([t for t in self._answer_times if t > now - 2.0]),
                "unanswered": self.unanswered,
                "device": self.device_info or "unknown",
            }
            if last is not None:
                info.update(
                    distance_m=round(last["distance"] / 1000.0, 3),
                    confidence=last["confidence"],
                    ping_number=last.get("ping_number"),
                )
            state, why = HealthState.FAULT, None
            if last is None:
                state, why = HealthState.MISSING, f"no answer ({self.link_error or 'not answering yet'})"
            elif self._last_t is not None and now - self._last_t > self.timeout:
                why = f"lost: silent for {now - self._last_t:.2f} s" + (
                    f" ({self.link_error})" if self.link_error else ""
                )
            elif self._ping_number_t is not None and now - self._ping_number_t > self.timeout:
                why = f"lost: not measuring (ping number {self._ping_number} for {now - self._ping_number_t:.2f} s)"
            elif self._altitude_t is None or now - self._altitude_t > self.timeout:
                state, why = HealthState.DEGRADED, f"confidence {last['confidence']} % below {self.min_confidence} %"
        if why:
            return Health(state, now, f"Ping echosounder: {why}; altitude from it unknown", info)
        return Health(HealthState.OK, now, "", info)
