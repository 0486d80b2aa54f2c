"""One link to a Reach arm, serial (RS-232/RS-485 through a USB adapter, pyserial)
or UDP (the Bravo's Ethernet), shared by the arm's joints and its jaw.

:meth:`ReachLink.shared` hands the arm and the jaw devices the same link when
their configs name the same port or address. The link:

* opens at :meth:`ReachLink.acquire` (the first user's ``connect``): a serial
  device that does not exist, or a host that does not resolve, raises
  :class:`hal.drivers.setup_checks.SetupError` naming the config field; a link
  that breaks later is reopened every :data:`REOPEN_PERIOD` s;
* reads in its own thread, splits the stream into packets
  (:class:`hal.drivers.reach_protocol.FrameDecoder`, bad frames counted and
  skipped) and hands each to the handler registered for its device id,
  stamped with its arrival time on the backend clock;
* writes from a writer thread: :meth:`ReachLink.post` only queues frames (a
  control step never blocks on the port) and wakes it; all frames queued in one
  step go out in one write (one datagram over UDP);
* starts the **guardian** (:mod:`hal.drivers.reach_guardian`, with
  ``guardian: true``), a separate process that sends zero velocity and STANDBY
  to every device of the link when this process dies (even by SIGKILL) or its
  control loop stops commanding an enabled arm for ``guard_timeout`` s; and
  sends the same stop itself at exit (atexit) and on SIGTERM / SIGHUP when
  nothing else handles them (the protocol has no timeout on a velocity demand:
  see docs/faults.md).
"""

from __future__ import annotations

import atexit
import logging
import signal
import socket
import subprocess
import sys
import threading
import time
import weakref
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

from hal.drivers.reach_protocol import FrameDecoder, Mode, Packet, PacketId, encode, encode_floats
from hal.drivers.realtime import STEP_GATE
from hal.drivers.setup_checks import SetupError, check_serial_device, resolve_host

log = logging.getLogger(__name__)

#: Time (s) between attempts to reopen a broken link.
REOPEN_PERIOD = 0.5
#: Longest wait (s) for the guardian process to report that it holds its own link.
GUARDIAN_START_TIMEOUT = 5.0


@dataclass(frozen=True)
class LinkSpec:
    """Where the arm is: ``transport`` serial (``device``, ``baudrate``) or udp
    (``host``, ``port``, local ``local_port``, 0 = any); ``where`` names the config
    entry for errors; ``guardian`` / ``guard_timeout`` (s) see the module docstring."""

    transport: str
    device: str | None = None
    baudrate: int = 115200
    host: str = ""
    port: int = 6789
    local_port: int = 0
    where: str = "reach arm"
    guardian: bool = True
    guard_timeout: float = 0.5

    @property
    def key(self) -> tuple[Any, ...]:
        return ("serial", self.device) if self.transport == "serial" else ("udp", self.host, self.port)

    @property
    def address(self) -> str:
        return str(self.device) if self.transport == "serial" else f"{self.host}:{self.port}"


def stop_frames(devices: list[int]) -> bytes:
    """Zero velocity, then STANDBY, for each device: the stop sent on every exit path."""
    out = b"".join(encode_floats(d, PacketId.VELOCITY, [0.0]) for d in devices)
    return out + b"".join(encode(d, PacketId.MODE, bytes((Mode.STANDBY,))) for d in devices)


Handler = Callable[[Packet, float], None]


class ReachLink:
    """See the module docstring. ``clock``: the backend clock (s)."""

    _registry: dict[tuple[Any, ...], ReachLink] = {}
    _registry_lock = threading.Lock()

    @classmethod
    def shared(cls, spec: LinkSpec, clock: Callable[[], float]) -> ReachLink:
        """The link for ``spec``'s port/address in this process (one per address)."""
        with cls._registry_lock:
            link = cls._registry.get(spec.key)
            if link is None or link._closed_for_good:
                link = cls._registry[spec.key] = cls(spec, clock)
            return link

    def __init__(self, spec: LinkSpec, clock: Callable[[], float]) -> None:
        self.spec = spec
        self._clock = clock
        self._handlers: dict[int, Handler] = {}
        self._users = 0
        self._lock = threading.Lock()
        self._wake = threading.Condition(self._lock)
        self._queue: list[bytes] = []
        self._stop = threading.Event()
        self._threads: list[threading.Thread] = []
        self._serial: Any = None
        self._sock: socket.socket | None = None
        self._peer: tuple[str, int] | None = None
        self.decoder = FrameDecoder()
        self.link_state = "closed"
        self.link_error = ""
        self.opened_once = False
        self.opened_at: float | None = None  # s, backend clock: the rates' window starts there
        self.last_rx: float | None = None
        self._rx_counts: list[tuple[float, int]] = []  # (arrival, packets), last 2 s
        self._rx_bytes: list[tuple[float, int]] = []
        self.tx_bytes = 0
        self._tx_times: list[tuple[float, int]] = []
        self._guardian: subprocess.Popen[bytes] | None = None
        self.guardian_note = ""
        self._armed = False
        self._closed_for_good = False
        self._prev_signals: dict[int, Any] = {}

    # ------------------------------------------------------------------ users
    def register(self, device_id: int, handler: Handler) -> None:
        with self._lock:
            if device_id in self._handlers:
                raise SetupError(f"{self.spec.where}: device id 0x{device_id:02X} is used twice on {self.spec.address}")
            self._handlers[device_id] = handler

    def unregister(self, device_id: int) -> None:
        with self._lock:
            self._handlers.pop(device_id, None)

    @property
    def devices(self) -> list[int]:
        return sorted(self._handlers)

    def acquire(self) -> None:
        """First user: check the set-up, open, start the threads and the guardian."""
        with self._lock:
            self._users += 1
            if self._users > 1:
                return
        try:
            self._check_setup()
            if self.spec.guardian:
                self._start_guardian()
            self._open()
        except Exception:
            with self._lock:
                self._users -= 1
            self._stop_guardian()
            self._close_port()
            raise
        self._stop.clear()
        for target, name in ((self._reader, "reach-reader"), (self._writer, "reach-writer")):
            th = threading.Thread(target=target, name=name, daemon=True)
            th.start()
            self._threads.append(th)
        _LIVE.add(self)
        self._install_signal_stop()

    def release(self) -> None:
        """Last user: send the stop, end the threads, the guardian and the port."""
        with self._lock:
            self._users = max(0, self._users - 1)
            if self._users:
                return
        self.send_stop_now()
        self._stop.set()
        with self._wake:
            self._wake.notify_all()
        for th in self._threads:
            th.join(timeout=2.0)
        self._threads.clear()
        self._stop_guardian()
        self._close_port()
        self._restore_signals()
        _LIVE.discard(self)
        self._closed_for_good = True
        self.link_state = "closed"

    # ------------------------------------------------------------------ set-up
    def _check_setup(self) -> None:
        s = self.spec
        if s.transport == "serial":
            check_serial_device(s.device, s.where, "Reach arm link")
        else:
            self._peer = (resolve_host(s.host, s.where, "Reach arm link"), s.port)

    def _open(self) -> None:
        s = self.spec
        try:
            if s.transport == "serial":
                import serial  # pyserial

                self._serial = serial.Serial(s.device, s.baudrate, timeout=0.05, write_timeout=0.5)
            else:
                sock = socket.socket(socket.AF_INET6 if ":" in self._peer[0] else socket.AF_INET, socket.SOCK_DGRAM)  # type: ignore[index]
                sock.bind(("", s.local_port))
                sock.settimeout(0.05)
                self._sock = sock
        except Exception as exc:  # noqa: BLE001 - pyserial and sockets raise many kinds
            self._close_port()
            raise SetupError(f"{s.where}: cannot open the Reach arm link {s.address}: {exc}") from None
        self.decoder.reset()
        self.link_state, self.link_error, self.opened_once = "open", "", True
        self.opened_at = self._clock()

    def _close_port(self) -> None:
        for h in (self._serial, self._sock):
            if h is not None:
                try:
                    h.close()
                except Exception:  # noqa: BLE001
                    pass
        self._serial = self._sock = None

    # ------------------------------------------------------------------ guardian
    def _start_guardian(self) -> None:
        import json

        s = self.spec
        arg = json.dumps(
            {
                "transport": s.transport,
                "device": s.device,
                "baudrate": s.baudrate,
                "host": self._peer[0] if self._peer else s.host,
                "port": s.port,
                "devices": self.devices,
                "guard_timeout": s.guard_timeout,
            }
        )
        proc = subprocess.Popen(
            [sys.executable, "-m", "hal.drivers.reach_guardian", arg],
            stdin=subprocess.PIPE,
            stdout=subprocess.PIPE,
            start_new_session=True,  # not in our process group: a group kill or Ctrl-C does not reach it
        )
        assert proc.stdout is not None
        line = b""
        deadline = time.monotonic() + GUARDIAN_START_TIMEOUT
        import select

        while time.monotonic() < deadline:
            r, _, _ = select.select([proc.stdout], [], [], 0.1)
            if r:
                line = proc.stdout.readline()
                break
            if proc.poll() is not None:
                break
        if not line.startswith(b"READY"):
            proc.kill()
            raise SetupError(f"{s.where}: the Reach guardian process did not start ({line.decode(errors='replace')!r})")
        self._guardian = proc
        threading.Thread(target=self._guardian_reports, args=(proc,), name="reach-guardian-out", daemon=True).start()

    def _guardian_reports(self, proc: subprocess.Popen[bytes]) -> None:
        assert proc.stdout is not None
        for raw in proc.stdout:
            text = raw.decode(errors="replace").strip()
            if text.startswith("STOPPED"):
                self.guardian_note = text[len("STOPPED") :].strip()
                log.error("Reach guardian stopped the arm: %s", self.guardian_note)

    def _tell_guardian(self, what: bytes) -> None:
        g = self._guardian
        if g is None or g.stdin is None:
            return
        try:
            g.stdin.write(what)
            g.stdin.flush()
        except (OSError, ValueError):
            pass

    def _stop_guardian(self) -> None:
        g, self._guardian = self._guardian, None
        if g is None:
            return
        try:
            if g.stdin is not None:
                g.stdin.write(b"Q")  # a clean end: stop once more, then quit
                g.stdin.close()
            g.wait(timeout=2.0)
        except (OSError, ValueError, subprocess.TimeoutExpired):
            g.kill()

    def set_armed(self, armed: bool) -> None:
        """An enabled device may move: the guardian watches the commands' flow while armed."""
        self._armed = armed
        self.guardian_note = "" if armed else self.guardian_note
        self._tell_guardian(b"A" if armed else b"D")

    # ------------------------------------------------------------------ exit paths
    def send_stop_now(self) -> None:
        """Zero velocity and STANDBY to every device, written now from this thread."""
        frames = stop_frames(self.devices)
        try:
            self._write(frames)
        except OSError:
            pass

    def _install_signal_stop(self) -> None:
        if threading.current_thread() is not threading.main_thread():
            return
        for sig in (signal.SIGTERM, signal.SIGHUP):
            previous = signal.getsignal(sig)
            if previous not in (signal.SIG_DFL, None):
                continue  # someone handles it (the supervisor's abort path): it closes the devices

            def on_signal(signum: int, frame: Any, _prev: Any = previous) -> None:
                for link in list(_LIVE):
                    link.send_stop_now()
                signal.signal(signum, signal.SIG_DFL)
                signal.raise_signal(signum)

            self._prev_signals[sig] = previous
            signal.signal(sig, on_signal)

    def _restore_signals(self) -> None:
        if threading.current_thread() is not threading.main_thread():
            return
        for sig, previous in self._prev_signals.items():
            signal.signal(sig, previous)
        self._prev_signals.clear()

    # ------------------------------------------------------------------ writing
    def post(self, frames: bytes) -> None:
        """Queue frames for the writer thread (never blocks on the port)."""
        with self._wake:
            self._queue.append(frames)
            self._wake.notify()

    def _write(self, data: bytes) -> None:
        if self._serial is not None:
            self._serial.write(data)
        elif self._sock is not None and self._peer is not None:
            self._sock.sendto(data, self._peer)
        else:
            raise OSError("link closed")
        now = self._clock()
        self.tx_bytes += len(data)
        self._tx_times = [x for x in self._tx_times if x[0] > now - 2.0] + [(now, len(data))]

    def _writer(self) -> None:
        while not self._stop.is_set():
            with self._wake:
                while not self._queue and not self._stop.is_set():
                    self._wake.wait(0.1)
                batch, self._queue = self._queue, []
            if not batch or self.link_state != "open":
                continue
            try:
                self._write(b"".join(batch))
            except Exception as exc:  # noqa: BLE001 - a broken port is the reader's to reopen
                self.link_error = f"write failed: {exc}"
                continue
            if self._armed:
                self._tell_guardian(b"T")

    # ------------------------------------------------------------------ reading
    def _reader(self) -> None:
        while not self._stop.is_set():
            if self.link_state != "open":
                try:
                    self._open()
                    log.info("Reach arm link %s reopened", self.spec.address)
                except SetupError as exc:
                    self.link_error = str(exc)
                    self._stop.wait(REOPEN_PERIOD)
                    continue
            try:
                data = self._read()
            except OSError as exc:
                self.link_state, self.link_error = "lost", f"link {self.spec.address} lost: {exc}"
                log.warning("Reach arm %s", self.link_error)
                self._close_port()
                self._stop.wait(REOPEN_PERIOD)
                continue
            if not data:
                continue
            now = self._clock()  # stamped on arrival
            STEP_GATE.wait()  # decode after the control loop's step, not during it
            packets = self.decoder.feed(data)
            self._rx_bytes = [x for x in self._rx_bytes if x[0] > now - 2.0] + [(now, len(data))]
            if packets:
                self.last_rx = now
                self._rx_counts = [x for x in self._rx_counts if x[0] > now - 2.0] + [(now, len(packets))]
            handlers = self._handlers
            for p in packets:
                h = handlers.get(p.device_id)
                if h is not None:
                    h(p, now)

    def _read(self) -> bytes:
        if self._serial is not None:
            import serial

            try:
                return bytes(self._serial.read(self._serial.in_waiting or 1))
            except (serial.SerialException, TypeError) as exc:
                raise OSError(str(exc)) from None
        if self._sock is not None:
            try:
                data, _addr = self._sock.recvfrom(65536)
            except TimeoutError:
                return b""
            except ConnectionRefusedError:
                return b""  # ICMP port unreachable: nobody listens there now; silence shows it
            return data
        raise OSError("link closed")

    # ------------------------------------------------------------------ diagnostics
    def info(self, now: float) -> dict[str, Any]:
        """Figures for ``maris hal check``: link state, rates, decoder errors."""
        # over the last second, once the link has been open that long (its set-up burst is not a rate)
        measured = self.opened_at is not None and now - self.opened_at >= 1.0
        sent = sum(n for t, n in self._tx_times if t > now - 1.0) if measured else None
        received = sum(n for t, n in self._rx_bytes if t > now - 1.0) if measured else None
        info: dict[str, Any] = {
            "link": f"{self.spec.transport} {self.spec.address}",
            "link_state": self.link_state,
            "rx_packets_per_s": sum(n for t, n in self._rx_counts if t > now - 1.0) if measured else None,
            "rx_bytes_per_s": received,
            "tx_bytes_per_s": sent,
            "rejected": dict(self.decoder.errors),
            "guardian": "running" if self._guardian is not None and self._guardian.poll() is None else "off",
        }
        if self.spec.transport == "serial" and sent is not None and received is not None:
            # both directions over one 8N1 line's capacity: RS-485 is half duplex, so they share it
            info["line_load"] = round((sent + received) / (self.spec.baudrate / 10.0), 3)
        if self.link_error:
            info["link_error"] = self.link_error
        return info


_LIVE: weakref.WeakSet[ReachLink] = weakref.WeakSet()


@atexit.register
def _stop_all_at_exit() -> None:
    """Interpreter exit with a link still open (no close ran): stop its devices."""
    for link in list(_LIVE):
        link.send_stop_now()
