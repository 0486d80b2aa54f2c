"""Python ``logging`` records (canopen, python-can, pymavlink and our drivers
warn through it) routed to the run log and, briefly, the terminal, instead of
raw lines on stderr.

During a run, :class:`LogCapture` sits on the root logger (WARNING and up). Its
handler only queues records (drivers log from their own threads); the
supervisor's loop calls :meth:`LogCapture.drain`, which turns each record into
a ``python_log`` event in the run log (level ``warning``; the logger name and
original level in its fields). The terminal front end shows the first
occurrence of each distinct message and counts the rest (:class:`BriefFilter`).

Outside a run (``maris hal check``, ``validate``), :func:`install_terminal_logging`
prints each distinct warning once, on one line, as ``warning: LOGGER: message``.
"""

from __future__ import annotations

import logging
import sys
from collections import deque
from collections.abc import Callable
from types import TracebackType
from typing import Any, NamedTuple, Protocol, TextIO

#: Longest message text kept (characters).
MAX_TEXT = 400

#: ``emit(kind, message, **fields)``: :meth:`mission.runtime.context.EventSink.emit`.
Emit = Callable[..., Any]


class LogLine(NamedTuple):
    """One Python logging record, as a run keeps it."""

    logger: str
    level: str
    text: str


class RunLogCapture(Protocol):
    """The capture of Python logging records during a run: entered for the run, drained
    by the loop's thread (each record becomes a ``python_log`` event)."""

    def __enter__(self) -> RunLogCapture: ...

    def __exit__(
        self, kind: type[BaseException] | None, exc: BaseException | None, tb: TracebackType | None
    ) -> None: ...

    def drain(self) -> int: ...


class LogCaptureFactory(Protocol):
    """``log_capture(emit)``: the :class:`RunLogCapture` of a run (:class:`LogCapture`, or
    the recording one of :mod:`mission.replay.record`)."""

    def __call__(self, emit: Emit) -> RunLogCapture: ...


class _QueueHandler(logging.Handler):
    def __init__(self, queue: deque[LogLine]) -> None:
        super().__init__(logging.WARNING)
        self.queue = queue

    def emit(self, record: logging.LogRecord) -> None:
        try:
            self.queue.append(LogLine(record.name, record.levelname, record.getMessage()[:MAX_TEXT]))
        except Exception:  # noqa: BLE001 - a bad format string must not break the logging thread
            self.handleError(record)


class LogCapture:
    """Root-logger capture for the duration of a run (context manager)."""

    def __init__(self, emit: Emit, max_queue: int = 10000) -> None:
        self._emit = emit
        self._queue: deque[LogLine] = deque(maxlen=max_queue)
        self._handler = _QueueHandler(self._queue)
        self._root = logging.getLogger()
        self._saved_level = self._root.level
        self._suspended: list[logging.Handler] = []

    def __enter__(self) -> LogCapture:
        self.install()
        return self

    def __exit__(self, kind: type[BaseException] | None, exc: BaseException | None, tb: TracebackType | None) -> None:
        self.drain()
        self.remove()

    def install(self) -> None:
        """Queue the root logger's records (WARNING and up) from now on."""
        # the run's events reach the terminal through the front end: no second, raw copy
        self._suspended = [h for h in self._root.handlers if isinstance(h, _TerminalHandler)]
        for h in self._suspended:
            self._root.removeHandler(h)
        self._root.addHandler(self._handler)
        if self._root.level > logging.WARNING or self._root.level == logging.NOTSET:
            self._root.setLevel(logging.WARNING)

    def remove(self) -> None:
        """Stop queueing; the root logger as it was before :meth:`install`."""
        self._root.removeHandler(self._handler)
        for h in self._suspended:
            self._root.addHandler(h)
        self._root.setLevel(self._saved_level)

    def take(self) -> list[LogLine]:
        """The queued records, removed from the queue, oldest first (not emitted)."""
        items = []
        while self._queue:
            items.append(self._queue.popleft())
        return items

    def drain(self) -> int:
        """Emit queued records as ``python_log`` events (call from the loop's thread)."""
        n = 0
        while self._queue:
            self.emit_record(*self._queue.popleft())
            n += 1
        return n

    def emit_record(self, name: str, level: str, text: str) -> None:
        """One record (logger name, level name, message) as a ``python_log`` event."""
        self._emit("python_log", f"{name}: {text}", level="warning", logger=name, log_level=level)


class BriefFilter:
    """Decides which repeated messages reach the terminal: each distinct text once."""

    def __init__(self) -> None:
        self.seen: dict[str, int] = {}

    def first(self, text: str) -> bool:
        """True the first time ``text`` is seen (later ones are only counted)."""
        self.seen[text] = self.seen.get(text, 0) + 1
        return self.seen[text] == 1

    @property
    def repeats(self) -> int:
        return sum(n - 1 for n in self.seen.values())


class _TerminalHandler(logging.Handler):
    def __init__(self, stream: TextIO) -> None:
        super().__init__(logging.WARNING)
        self.stream = stream
        self.brief = BriefFilter()

    def emit(self, record: logging.LogRecord) -> None:
        try:
            text = f"{record.levelname.lower()}: {record.name}: {record.getMessage()[:MAX_TEXT]}"
            if self.brief.first(text):
                self.stream.write(text + "\n")
                self.stream.flush()
        except Exception:  # noqa: BLE001
            self.handleError(record)


def install_terminal_logging(stream: TextIO | None = None) -> logging.Handler:
    """One-line, de-duplicated warnings on ``stream`` (default stderr) for commands without a run log."""
    root = logging.getLogger()
    for h in root.handlers:
        if isinstance(h, _TerminalHandler):
            return h
    handler = _TerminalHandler(stream or sys.stderr)
    root.addHandler(handler)
    return handler
