"""Campaign progress on the terminal.

On a TTY: one bar redrawn in place (``\\r``). Otherwise (CI logs, pipes): a plain
line every 10 % of the runs or every ``interval_s`` of wall time, and at the end.
"""

from __future__ import annotations

import sys
import time
from typing import TextIO

from mission.campaign.records import RunRecord


def _fmt_duration(seconds: float) -> str:
    seconds = max(0, int(round(seconds)))
    m, s = divmod(seconds, 60)
    h, m = divmod(m, 60)
    return f"{h}h{m:02d}m" if h else (f"{m}m{s:02d}s" if m else f"{s}s")


class Progress:
    """Callable sink for :func:`mission.campaign.executor.execute`'s ``on_record``."""

    def __init__(
        self,
        total: int,
        stream: TextIO | None = None,
        *,
        label: str = "runs",
        interval_s: float = 30.0,
        width: int = 30,
        tty: bool | None = None,
    ):
        self.total = total
        self.stream = stream if stream is not None else sys.stderr
        self.label = label
        self.interval_s = interval_s
        self.width = width
        self.tty = self.stream.isatty() if tty is None else tty
        self.done = 0
        self.successes = 0
        self.errors = 0
        self._start = time.monotonic()
        self._last_line = self._start
        self._last_decile = 0

    def status(self) -> str:
        """One-line text: counts, success so far, elapsed time and estimate left."""
        elapsed = time.monotonic() - self._start
        eta = elapsed / self.done * (self.total - self.done) if self.done else float("nan")
        eta_s = _fmt_duration(eta) if self.done else "?"
        err = f", {self.errors} errors" if self.errors else ""
        return (
            f"{self.done}/{self.total} {self.label}, {self.successes} successes{err}, "
            f"elapsed {_fmt_duration(elapsed)}, left ~{eta_s}"
        )

    def __call__(self, record: RunRecord) -> None:
        self.done += 1
        self.successes += record.success
        self.errors += record.outcome == "error"
        if self.tty:
            filled = int(self.width * self.done / max(self.total, 1))
            bar = "#" * filled + "-" * (self.width - filled)
            end = "\n" if self.done >= self.total else ""
            self.stream.write(f"\r[{bar}] {self.status()}\x1b[K{end}")
            self.stream.flush()
            return
        now = time.monotonic()
        decile = (10 * self.done) // max(self.total, 1)
        if self.done >= self.total or decile > self._last_decile or now - self._last_line >= self.interval_s:
            self._last_decile = decile
            self._last_line = now
            self.stream.write(self.status() + "\n")
            self.stream.flush()
