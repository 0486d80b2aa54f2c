"""Live progress of a run for the terminal.

On a TTY one line is rewritten in place (``\\r``) at most every
``tty_period_s`` of wall time; otherwise a plain line is printed every
``plain_period_s`` of mission time (log-friendly, deterministic).
"""

from __future__ import annotations

import sys
import time
from typing import TextIO


class ProgressDisplay:
    def __init__(
        self,
        stream: TextIO | None = None,
        *,
        tty: bool | None = None,
        tty_period_s: float = 0.2,
        plain_period_s: float = 10.0,
    ) -> None:
        self.stream = stream or sys.stdout
        self.tty = self.stream.isatty() if tty is None else tty
        self.tty_period_s = tty_period_s
        self.plain_period_s = plain_period_s
        self._last_wall = -1e9
        self._next_plain = 0.0
        self._width = 0

    @staticmethod
    def line(t: float, state: str, action: str | None, leaf: str | None, extra: str = "") -> str:
        text = f"t={t:7.1f} s  {state:<9} action={action or '-':<10} leaf={leaf or '-'}"
        return text + (f"  {extra}" if extra else "")

    def update(self, t: float, state: str, action: str | None, leaf: str | None, extra: str = "") -> None:
        if self.tty:
            now = time.monotonic()
            if now - self._last_wall < self.tty_period_s:
                return
            self._last_wall = now
            text = self.line(t, state, action, leaf, extra)
            pad = max(0, self._width - len(text))
            self._width = len(text)
            self.stream.write("\r" + text + " " * pad)
            self.stream.flush()
        elif t >= self._next_plain:
            self._next_plain = t + self.plain_period_s
            self.stream.write(self.line(t, state, action, leaf, extra) + "\n")
            self.stream.flush()

    def message(self, text: str) -> None:
        """A line that must not be overwritten (event, state change)."""
        if self.tty and self._width:
            self.stream.write("\r" + " " * self._width + "\r")
            self._width = 0
        self.stream.write(text + "\n")
        self.stream.flush()

    def close(self) -> None:
        if self.tty and self._width:
            self.stream.write("\n")
            self.stream.flush()
            self._width = 0
