"""Read a run log one message at a time, in constant memory.

:class:`LogStream` iterates ``(topic, message dict)`` in file order with the
``mcap`` package's stream reader (one chunk decompressed at a time; JSON
channels only, like ``read_log``), so memory
does not grow with the log's length; :func:`mission.logs.reader.read_log`
instead keeps every message (plots, export). Like ``read_log`` it tolerates a
file cut short (a run killed mid-way): iteration stops at the last complete
record and :attr:`LogStream.truncated` / :attr:`LogStream.stop_reason` say so.
"""

from __future__ import annotations

from collections.abc import Iterable, Iterator
from pathlib import Path

import orjson
from mcap.records import Channel, Footer, Message, Metadata
from mcap.stream_reader import StreamReader

from mission.logs.errors import LogError


class LogStream:
    """Iterate once: ``for topic, msg in LogStream(path): ...``; then check ``truncated``.

    ``topics``: decode and yield only these (the others are skipped undecoded,
    which is most of the time spent); :attr:`last_time` is the backend time (s)
    of the last message of any topic, :attr:`messages` counts them all;
    :attr:`time_offset_ns` is the log's log time minus backend time (ns)."""

    def __init__(self, path: str | Path, topics: Iterable[str] | None = None) -> None:
        self.path = Path(path)
        self.topics = None if topics is None else frozenset(topics)
        self.truncated = False
        self.stop_reason = ""
        self.messages = 0
        self.time_offset_ns = 0
        self._offset_known = False
        self._last_ns: int | None = None

    @property
    def last_time(self) -> float | None:
        """Backend time (s) of the latest message of any topic (None before one is read)."""
        if self._last_ns is None:
            return None
        return (self._last_ns - self.time_offset_ns) / 1e9  # correctly rounded: 15950000000 ns -> 15.95 s, as logged

    def _take_metadata(self, record: Metadata) -> None:
        """The run's time offset from its ``maris.run`` record (none: simulated time, 0)."""
        if record.name == "maris.run":
            try:
                self.time_offset_ns, self._offset_known = int(record.metadata.get("time_offset_ns", "0")), True
            except ValueError:
                pass

    def __iter__(self) -> Iterator[tuple[str, dict]]:
        try:
            f = open(self.path, "rb")
        except OSError as exc:
            raise LogError(f"{self.path}: cannot open: {exc}") from None
        channels: dict[int, str] = {}
        complete = False
        with f:
            reader = StreamReader(f, skip_magic=False)
            try:
                for record in reader.records:
                    if isinstance(record, Channel):
                        if record.message_encoding == "json":  # the Foxglove protobuf channels are skipped
                            channels[record.id] = record.topic
                    elif isinstance(record, Message):
                        if self._last_ns is None or record.log_time > self._last_ns:
                            self._last_ns = record.log_time
                        topic = channels.get(record.channel_id)
                        if topic is None:
                            continue
                        self.messages += 1
                        if self.topics is not None and topic not in self.topics:
                            continue
                        try:
                            msg = orjson.loads(record.data)
                        except ValueError:
                            continue
                        if not self._offset_known and isinstance(msg.get("t"), (int, float)):
                            # no maris.run record (cut before it, or an older log): the writer
                            # stamps log time = offset + backend t, so the first message tells it
                            self.time_offset_ns, self._offset_known = record.log_time - round(msg["t"] * 1e9), True
                        yield topic, msg
                    elif isinstance(record, Metadata):
                        self._take_metadata(record)
                    elif isinstance(record, Footer):
                        complete = True
            except Exception as exc:  # noqa: BLE001 - a cut-off file ends in a partial record
                if not channels:
                    raise LogError(f"{self.path}: not an MCAP run log ({type(exc).__name__}: {exc})") from None
                self.stop_reason = f"{type(exc).__name__}: {exc}" if str(exc) else type(exc).__name__
        self.truncated = not complete
        if self.truncated and not self.stop_reason:
            self.stop_reason = "no footer"
