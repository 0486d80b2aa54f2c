"""The run log's periodic flush, at the end of a step while the loop runs.

:class:`mission.logs.writer.RunLogWriter` finishes its open chunk and flushes the
file every ``flush_interval_s`` (0.5 s) of wall time, for crash safety. Left to
itself it does so inside whichever write finds the interval over, i.e. in the
middle of some step's work, often a tree step's, the slowest of the period; a
flush compresses, checksums and writes the chunk. While the supervisor's loop
runs, :class:`LoopFlush` turns that off and the loop calls the writer's
``flush_if_due`` once per step, after the step's work (commands sent, messages
written) and before ``backend.advance``: in real time, in the part of the
period the loop would spend waiting for the next tick. The file is flushed
every interval all the same (at most one base step later).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any


class LoopFlush:
    """The loop's control of ``log``'s flushes (None, or a log without the two
    methods: nothing to do) and the wall time (s) of each flush it made."""

    def __init__(self, log: Any) -> None:
        usable = log is not None and hasattr(log, "flush_on_write") and callable(getattr(log, "flush_if_due", None))
        self.log = log if usable else None
        #: Wall time (s) of each flush made at the end of a step.
        self.times: list[float] = []

    @property
    def flush_if_due(self) -> Callable[[], bool] | None:
        """The writer's ``flush_if_due`` (True when it flushed), None without a log."""
        return self.log.flush_if_due if self.log is not None else None

    def start(self) -> None:
        """The loop begins: writes no longer flush by themselves."""
        if self.log is not None:
            self.log.flush_on_write = False

    def stop(self) -> None:
        """The loop ended (or raised): writes flush by themselves again."""
        if self.log is not None:
            self.log.flush_on_write = True

    def summary(self) -> dict[str, float | int] | None:
        """``n``, ``p50_s``, ``max_s``, ``total_s`` of the flushes; None without any."""
        if not self.times:
            return None
        s = sorted(self.times)
        return {"n": len(s), "p50_s": s[len(s) // 2], "max_s": s[-1], "total_s": sum(s)}
