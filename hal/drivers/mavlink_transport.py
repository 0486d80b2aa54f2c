"""Byte transports for a MAVLink link, with loss detection and reconnect.

pymavlink's own connection classes print on every TCP EOF and either give up
or block while reconnecting; a ground station that must survive an autopilot
restart needs better. This module opens the socket (or serial port) itself and
hands raw bytes to a pymavlink parser (:class:`MavCodec`), so the link layer in
:mod:`hal.drivers.ardusub` decides what a loss means.

URLs (the pymavlink spellings):

* ``tcp:HOST:PORT``   - we connect to the autopilot (ArduSub SITL: ``tcp:127.0.0.1:5760``);
* ``tcpin:HOST:PORT`` - we listen and accept one autopilot connection;
* ``udpin:HOST:PORT`` - we bind and answer whoever sends to us (BlueOS default
  ``udpin:0.0.0.0:14550``);
* ``udpout:HOST:PORT`` / ``udp:HOST:PORT`` - we send to that address;
* ``/dev/ttyXXX`` or ``serial:/dev/ttyXXX`` (``baudrate`` from the config).

:meth:`Transport.read` returns ``b""`` when nothing arrived within its timeout
and raises :class:`LinkDown` when the link is gone (TCP EOF/reset, serial
unplugged); the caller closes, waits (back-off) and calls :meth:`Transport.open`
again. UDP has no connection: its loss shows as silence (heartbeat timeout).
"""

from __future__ import annotations

import select
import socket
from collections.abc import Callable
from typing import Any

import serial
from pymavlink.dialects.v20 import ardupilotmega as mavlink2


class LinkDown(OSError):
    """The transport lost its peer (EOF, reset, device gone) or could not open."""


class Transport:
    """One byte stream to the autopilot. ``url``: see the module docstring."""

    def __init__(self, url: str, baudrate: int = 115200) -> None:
        self.url = url
        self.baudrate = baudrate
        kind, _, rest = url.partition(":")
        if url.startswith("/dev/") or url.startswith("COM"):
            kind, rest = "serial", url
        self.kind = kind
        self.address: tuple[str, int] | str = rest
        if kind in ("tcp", "tcpin", "udpin", "udpout", "udp"):
            host, _, port = rest.rpartition(":")
            if not host or not port.isdigit():
                raise ValueError(f"MAVLink URL {url!r}: expected {kind}:HOST:PORT")
            self.address = (host, int(port))
        elif kind != "serial":
            raise ValueError(f"MAVLink URL {url!r}: unknown kind {kind!r} (tcp, tcpin, udpin, udpout, serial)")
        self._sock: socket.socket | None = None
        self._listen: socket.socket | None = None
        self._serial: Any = None
        self._peer: tuple[str, int] | None = None

    def _host_port(self) -> tuple[str, int]:
        """``(host, port)`` of a network link (set at init for every kind but serial)."""
        if isinstance(self.address, str):
            raise LinkDown(f"MAVLink URL {self.url!r}: {self.kind} needs HOST:PORT")
        return self.address

    @property
    def is_open(self) -> bool:
        return self._sock is not None or self._serial is not None

    @property
    def connection_oriented(self) -> bool:
        """True when a loss is seen as EOF (TCP, serial), False for UDP (silence only)."""
        return self.kind in ("tcp", "tcpin", "serial")

    def open(self, timeout: float = 2.0) -> None:
        """Open (connect, bind, accept or open the port); raises LinkDown with the reason."""
        self.close()
        try:
            if self.kind == "tcp":
                s = socket.create_connection(self._host_port(), timeout=timeout)
                s.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
                self._sock = s
            elif self.kind == "tcpin":
                if self._listen is None:
                    ls = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
                    ls.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
                    ls.bind(self._host_port())
                    ls.listen(1)
                    self._listen = ls
                r, _, _ = select.select([self._listen], [], [], timeout)
                if not r:
                    raise LinkDown(f"no autopilot connected to {self.url} within {timeout:g} s")
                self._sock, _ = self._listen.accept()
            elif self.kind == "udpin":
                s = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
                s.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
                s.bind(self._host_port())
                self._sock = s
            elif self.kind in ("udpout", "udp"):
                s = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
                self._sock = s
                self._peer = self._host_port()
            else:
                device = str(self.address).removeprefix("serial:")
                self._serial = serial.Serial(device, self.baudrate, timeout=0)
        except LinkDown:
            raise
        except (OSError, ImportError, ValueError) as exc:
            self.close()
            raise LinkDown(f"cannot open {self.url}: {exc}") from None
        if self._sock is not None:
            self._sock.setblocking(False)

    def close(self) -> None:
        """Close the stream (a tcpin listener stays bound for the next accept)."""
        for attr in ("_sock", "_serial"):
            h = getattr(self, attr)
            if h is not None:
                try:
                    h.close()
                except OSError:
                    pass
                setattr(self, attr, None)
        if self.kind == "udpin":
            self._peer = None

    def shutdown(self) -> None:
        """Close everything, the tcpin listener too."""
        self.close()
        if self._listen is not None:
            self._listen.close()
            self._listen = None

    def read(self, timeout: float) -> bytes:
        """Bytes that arrived within ``timeout`` s (``b""`` if none); LinkDown on loss."""
        if self._serial is not None:
            try:
                data = self._serial.read(4096)
            except OSError as exc:
                raise LinkDown(f"{self.url}: {exc}") from None
            if not data:
                select.select([], [], [], timeout)  # pyserial has no portable fd wait; bounded sleep
            return data
        s = self._sock
        if s is None:
            raise LinkDown(f"{self.url}: not open")
        r, _, _ = select.select([s], [], [], timeout)
        if not r:
            return b""
        try:
            if self.kind in ("udpin", "udpout", "udp"):
                data, addr = s.recvfrom(65535)
                if self.kind == "udpin":
                    self._peer = addr
                return data
            data = s.recv(65535)
        except (BlockingIOError, InterruptedError):
            return b""
        except OSError as exc:
            if self.kind in ("udpin", "udpout", "udp"):  # e.g. ICMP port unreachable: nobody listening yet
                return b""
            raise LinkDown(f"{self.url}: {exc}") from None
        if not data:
            raise LinkDown(f"{self.url}: connection closed by the autopilot")
        return data

    def write(self, buf: bytes) -> None:
        """Send ``buf``; silently dropped while closed or (udpin) before the first packet."""
        try:
            if self._serial is not None:
                self._serial.write(buf)
            elif self._sock is not None:
                if self.kind in ("udpin", "udpout", "udp"):
                    if self._peer is not None:
                        self._sock.sendto(buf, self._peer)
                else:
                    self._sock.sendall(buf)
        except OSError:
            pass  # a lost link shows up in read() / as a lost heartbeat


class MavCodec:
    """pymavlink MAVLink 2 encoder/decoder (ardupilotmega dialect) on a byte sink.

    ``send`` receives every encoded frame; :attr:`mav` is the pymavlink object
    whose ``*_send`` methods encode and hand the bytes to ``send``.
    """

    def __init__(self, send: Callable[[bytes], None], source_system: int, source_component: int) -> None:
        self._send = send
        self.mav = mavlink2.MAVLink(self, srcSystem=source_system, srcComponent=source_component)
        self.mav.robust_parsing = True

    def write(self, buf: bytes) -> None:  # pymavlink calls file.write(frame)
        self._send(bytes(buf))

    def parse(self, data: bytes) -> list[mavlink2.MAVLink_message]:
        """Decoded messages in ``data`` (bad frames come back as BAD_DATA and are dropped)."""
        out: list[mavlink2.MAVLink_message] = []
        try:
            msgs = self.mav.parse_buffer(data) or []
        except mavlink2.MAVError:
            return out
        for m in msgs:
            if m.get_type() != "BAD_DATA":
                out.append(m)
        return out
