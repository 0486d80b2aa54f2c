"""The Reach arm's guardian: a small process that stops the arm when the process
driving it cannot (started by :class:`hal.drivers.reach_link.ReachLink`)::

    python -m hal.drivers.reach_guardian '{"transport": "udp", "host": ..., "port": ..., "devices": [...]}'

The Reach protocol has no timeout on a velocity demand: an arm whose host dies
keeps moving at its last velocity until its joints reach their position limits.
The guardian opens its own handle on the link (the same serial device, or a UDP
socket to the arm), prints ``READY`` and then reads single bytes on stdin, a
pipe from the driver:

* ``A`` the arm is enabled, ``D`` disabled, ``T`` a batch of commands went out;
* ``Q`` a clean end (the driver stopped the arm itself): stop once more, exit;
* end of file: the driver's process is gone (exit, crash, SIGKILL; the kernel
  closes its end of the pipe at once): **stop** the arm, exit;
* no ``T`` for ``guard_timeout`` s while enabled (the process is stopped,
  SIGSTOP / Ctrl-Z, or its control loop hangs): **stop** the arm, print
  ``STOPPED <why>`` (the driver then reports a fault) and go on watching.

"Stop" is zero velocity then STANDBY for every device of the link and for all
devices (0xFF), sent three times 20 ms apart (a datagram may be lost). The
guardian runs in its own session, so a Ctrl-C or a kill of the driver's process
group does not reach it; it cannot help when this computer loses power or the
cable is cut (see docs/faults.md).
"""

from __future__ import annotations

import json
import os
import select
import socket
import sys
import time
from typing import Any

from hal.drivers.reach_link import stop_frames
from hal.drivers.reach_protocol import ALL_DEVICES


def _opener(cfg: dict[str, Any]) -> Any:
    """A write function on the guardian's own handle of the link."""
    if cfg["transport"] == "serial":
        import serial

        port = serial.Serial(cfg["device"], cfg.get("baudrate", 115200), timeout=0, write_timeout=0.5)
        return port.write
    sock = socket.socket(socket.AF_INET6 if ":" in cfg["host"] else socket.AF_INET, socket.SOCK_DGRAM)
    address = (cfg["host"], int(cfg["port"]))
    return lambda data: sock.sendto(data, address)


def main(argv: list[str] | None = None) -> int:
    cfg = json.loads((argv if argv is not None else sys.argv[1:])[0])
    write = _opener(cfg)
    frames = stop_frames(sorted(set(cfg.get("devices") or [])) + [ALL_DEVICES])
    timeout = float(cfg.get("guard_timeout", 0.5))

    def stop() -> None:
        for _ in range(3):
            try:
                write(frames)
            except OSError:
                pass
            time.sleep(0.02)

    print("READY", flush=True)
    fd = sys.stdin.fileno()
    armed, last_tick, tripped = False, time.monotonic(), False
    while True:
        r, _, _ = select.select([fd], [], [], 0.02)
        now = time.monotonic()
        if r:
            data = os.read(fd, 256)
            if not data:
                stop()  # the driver's process is gone
                return 0
            for b in data:
                c = chr(b)
                if c == "Q":
                    stop()
                    return 0
                if c == "A":
                    armed, last_tick, tripped = True, now, False
                elif c == "D":
                    armed = False
                elif c == "T":
                    last_tick, tripped = now, False
        if armed and not tripped and now - last_tick > timeout:
            stop()
            tripped = True
            print(
                f"STOPPED no command from the control loop for {now - last_tick:.2f} s (limit {timeout:g} s)",
                flush=True,
            )


if __name__ == "__main__":
    sys.exit(main())
