"""Run protocol peers (:mod:`hal.testing` simulators) as child processes, for
tests and bench checks.

Every peer is started with ``python -m MODULE ... --max-runtime 120`` (s; the
``max_runtime`` argument changes it, e.g. for a long benchmark), prints
``READY ...`` when serving and takes JSON commands on stdin. :meth:`Peer.stop`
asks it to quit and kills it after a bound.
"""

from __future__ import annotations

import json
import select
import socket
import subprocess
import sys
import time
from collections.abc import Callable
from pathlib import Path
from typing import IO, TypeVar

T = TypeVar("T")

CAN_GROUP = "239.74.163.2"
ROOT = Path(__file__).resolve().parents[2]  # the source tree, so `python -m hal.testing...` works


class Peer:
    """A peer process: ``ready`` holds what it printed after READY."""

    def __init__(self, module: str, *args: str, ready_timeout: float = 15.0, max_runtime: float = 120.0) -> None:
        self.proc = subprocess.Popen(
            [sys.executable, "-m", module, *args, "--max-runtime", f"{max_runtime:g}"],
            cwd=ROOT,
            stdin=subprocess.PIPE,
            stdout=subprocess.PIPE,
            text=True,
        )
        deadline = time.monotonic() + ready_timeout
        line = ""
        while time.monotonic() < deadline:
            r, _, _ = select.select([self.stdout], [], [], 0.2)
            if r:
                line = self.stdout.readline()
                if line.startswith("READY") or not line:
                    break
        if not line.startswith("READY"):
            self.stop()
            raise RuntimeError(f"peer {module} did not start (got {line!r})")
        self.ready = line[len("READY") :].strip()

    @property
    def stdout(self) -> IO[str]:
        """The peer's output (started with a pipe)."""
        if self.proc.stdout is None:
            raise RuntimeError("the peer has no output pipe")
        return self.proc.stdout

    def send(self, **cmd: object) -> None:
        if self.proc.stdin is None:
            raise RuntimeError("the peer has no input pipe")
        self.proc.stdin.write(json.dumps(cmd) + "\n")
        self.proc.stdin.flush()

    def stop(self) -> None:
        if self.proc.poll() is None:
            try:
                self.send(cmd="quit")
                self.proc.wait(timeout=3)
            except (OSError, subprocess.TimeoutExpired, ValueError):
                self.proc.kill()
                self.proc.wait(timeout=3)


def wait_until(predicate: Callable[[], T], timeout: float = 3.0, period: float = 0.02) -> T:
    """Poll ``predicate`` until true or ``timeout`` s; returns its last value."""
    deadline = time.monotonic() + timeout
    while True:
        ok = predicate()
        if ok or time.monotonic() > deadline:
            return ok
        time.sleep(period)


def free_udp_port() -> int:
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def peer_report(peer: Peer, timeout: float = 3.0) -> dict:
    """Ask a peer that supports ``{"cmd": "report"}`` for its state (the JSON after ``REPORT``)."""
    peer.send(cmd="report")
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        r, _, _ = select.select([peer.stdout], [], [], 0.2)
        if r:
            line = peer.stdout.readline()
            if line.startswith("REPORT "):
                return json.loads(line[len("REPORT ") :])
            if not line:
                break
    raise RuntimeError("peer did not report")


def free_tcp_port() -> int:
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]
