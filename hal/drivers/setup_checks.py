"""Set-up errors that no retry can mend, found at ``connect()`` instead of after
the preflight's wait: a serial device that does not exist (or that this user may
not open), a host name that does not resolve, a local address this computer
does not have. Each raises :class:`SetupError` naming the HAL config field at
``file:line:column`` (:func:`hal.config.site_of`), so ``maris run`` and
``maris hal check`` stop at once with the reason.

Only the unrecoverable cases are caught here. A device that exists but does not
answer yet (ArduSub still booting, a DVL not yet powered, a refused TCP
connection) is left to the drivers' own reconnecting and to the preflight.
"""

from __future__ import annotations

import errno
import ipaddress
import os
import socket
import threading

from hal.factory import DeviceUnavailable

#: Longest wait (s) for a host name to resolve before the start is refused.
RESOLVE_TIMEOUT = 1.5


class SetupError(DeviceUnavailable):
    """A device's set-up cannot work as configured; the message names the config field."""


def check_serial_device(path: str | None, where: str, what: str) -> None:
    """The serial device exists and this user may read and write it."""
    if not path:
        raise SetupError(f"{where}: {what}: no serial device given (e.g. /dev/ttyUSB0)")
    if not os.path.exists(path):
        raise SetupError(
            f"{where}: {what}: serial device {path} does not exist on this computer "
            "(adapter plugged in? `ls /dev/serial/by-id/` lists the ones present)"
        )
    if not os.access(path, os.R_OK | os.W_OK):
        raise SetupError(f"{where}: {what}: no permission to open {path} (add this user to its group, e.g. `dialout`)")


def _numeric(host: str) -> bool:
    try:
        ipaddress.ip_address(host)
    except ValueError:
        return False
    return True


def resolve_host(host: str, where: str, what: str, timeout: float = RESOLVE_TIMEOUT) -> str:
    """The host's first IPv4/IPv6 address; SetupError if the name does not resolve
    (or not within ``timeout`` s: the resolver of a field network without DNS can hang)."""
    if not host:
        raise SetupError(f"{where}: {what}: no host given")
    if _numeric(host):
        return host
    result: list[object] = []

    def lookup() -> None:
        try:
            result.append(socket.getaddrinfo(host, None, type=socket.SOCK_DGRAM)[0][4][0])
        except (OSError, UnicodeError) as exc:
            result.append(exc)

    th = threading.Thread(target=lookup, name="resolve", daemon=True)
    th.start()
    th.join(timeout)
    if not result:
        raise SetupError(f"{where}: {what}: host name `{host}` did not resolve within {timeout:g} s")
    if isinstance(result[0], BaseException):
        raise SetupError(f"{where}: {what}: host name `{host}` does not resolve ({result[0]})")
    return str(result[0])


def check_bindable(host: str, port: int, kind: int, where: str, what: str) -> None:
    """A local address this computer has and a port it may listen on (``kind``:
    socket.SOCK_DGRAM or SOCK_STREAM); binds and closes at once."""
    address = resolve_host(host, where, what)
    family = socket.AF_INET6 if ":" in address else socket.AF_INET
    s = socket.socket(family, kind)
    try:
        s.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        s.bind((address, port))
    except OSError as exc:
        why = {
            errno.EADDRNOTAVAIL: "is not an address of this computer",
            errno.EACCES: "needs privileges for that port",
            errno.EADDRINUSE: "is in use by another program",
        }.get(exc.errno or 0, str(exc))
        raise SetupError(f"{where}: {what}: cannot listen on {host}:{port}: the address {why}") from None
    finally:
        s.close()


def check_mavlink_url(url: str, where: str, what: str = "MAVLink link") -> None:
    """The MAVLink URL's serial device exists, its host resolves, its listening address binds
    (the spellings of :mod:`hal.drivers.mavlink_transport`)."""
    kind, _, rest = url.partition(":")
    if url.startswith(("/dev/", "COM")) or kind == "serial":
        check_serial_device(url.removeprefix("serial:"), where, what)
        return
    host, _, port = rest.rpartition(":")
    if kind in ("udpin", "tcpin"):
        check_bindable(host, int(port), socket.SOCK_DGRAM if kind == "udpin" else socket.SOCK_STREAM, where, what)
    elif kind in ("tcp", "udpout", "udp"):
        resolve_host(host, where, what)


def check_stream_source(params: dict, where: str, what: str) -> None:
    """A sensor's ``transport`` record (DVL, AHRS, Ping): the serial device or the host."""
    if params.get("transport") == "serial":
        check_serial_device(params.get("device"), where, what)
    else:
        resolve_host(str(params.get("host") or ""), where, what)
