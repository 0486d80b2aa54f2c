"""Operator control while a mission runs: keys, signals, scripted commands.

Commands are the strings ``pause``, ``resume``, ``abort`` (and ``stop_now``
for a second interrupt: skip the abort path, safe-stop at once).

* :class:`KeyReader`: single keys from a terminal in cbreak mode, polled without
  blocking (``p`` pause, ``r`` resume, space toggles, ``a``/``q`` abort). Used
  only when stdin is a TTY; the terminal is restored on close.
* :class:`SignalAbort`: SIGINT/SIGTERM -> ``abort`` (again -> ``stop_now``);
  previous handlers restored on close.
* :class:`ScriptedOperator`: commands at given backend times (tests, campaigns).
"""

from __future__ import annotations

import os
import select
import signal
import sys
from collections import deque
from collections.abc import Iterable

KEYMAP = {"p": "pause", "r": "resume", " ": "toggle", "a": "abort", "q": "abort"}
KEY_HELP = "keys: p pause, r resume, space toggle, a/q abort"


class CommandQueue:
    """Pending operator commands, oldest first (signal-handler safe: deque appends)."""

    def __init__(self) -> None:
        self._q: deque[tuple[str, str]] = deque()

    def put(self, command: str, source: str) -> None:
        self._q.append((command, source))

    def drain(self) -> list[tuple[str, str]]:
        out = []
        while self._q:
            out.append(self._q.popleft())
        return out


class KeyReader:
    """Non-blocking single-key reader on a TTY stdin."""

    def __init__(self, queue: CommandQueue, stream=None) -> None:
        self.queue = queue
        self.stream = stream or sys.stdin
        self._fd = self.stream.fileno()
        self._saved = None
        import termios
        import tty

        self._saved = termios.tcgetattr(self._fd)
        tty.setcbreak(self._fd)

    def poll(self) -> None:
        """Read whatever keys are waiting, never blocking."""
        while select.select([self._fd], [], [], 0)[0]:
            ch = os.read(self._fd, 1).decode(errors="ignore").lower()
            if not ch:
                break
            cmd = KEYMAP.get(ch)
            if cmd:
                self.queue.put(cmd, f"key {ch!r}")

    def close(self) -> None:
        if self._saved is not None:
            import termios

            termios.tcsetattr(self._fd, termios.TCSADRAIN, self._saved)
            self._saved = None


class SignalAbort:
    """SIGINT/SIGTERM request an abort; a second one requests ``stop_now``."""

    def __init__(self, queue: CommandQueue, signals: Iterable[int] = (signal.SIGINT, signal.SIGTERM)) -> None:
        self.queue = queue
        self.count = 0
        self._previous: dict[int, object] = {}
        for s in signals:
            self._previous[s] = signal.signal(s, self._handle)

    def _handle(self, signum: int, frame) -> None:
        self.count += 1
        name = signal.Signals(signum).name
        self.queue.put("abort" if self.count == 1 else "stop_now", name)

    def close(self) -> None:
        for s, h in self._previous.items():
            signal.signal(s, h)
        self._previous.clear()


class ScriptedOperator:
    """Commands issued at backend times: ``[(t_s, "pause"), (t_s, "resume")]``."""

    def __init__(self, queue: CommandQueue, script: Iterable[tuple[float, str]]) -> None:
        self.queue = queue
        self._pending = sorted(script)

    def poll(self, now: float) -> None:
        while self._pending and self._pending[0][0] <= now:
            t, cmd = self._pending.pop(0)
            self.queue.put(cmd, f"script @ {t:g} s")
