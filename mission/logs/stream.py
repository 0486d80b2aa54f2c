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

from pathlib import Path
from typing import Iterable, Iterator

import orjson
from mcap.records import Channel, Footer, Message
from mcap.stream_reader import StreamReader

from mission.logs.reader import LogError


class LogStream:
    """Iterate once: ``for topic, msg in LogStream(path): ...``; then check ``truncated``.

    ``topics``: decode and yield only these (the others are skipped undecoded,
    which is most of the time spent); :attr:`last_time` is the log time (s) of
    the last message of any topic, :attr:`messages` counts them all."""

    def __init__(self, path: str | Path, topics: Iterable[str] | None = None) -> None:
        self.path = Path(path)
        self.topics = None if topics is None else frozenset(topics)
        self.truncated = False
        self.stop_reason = ""
        self.messages = 0
        self.last_time: float | None = None

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
                        t = record.log_time / 1e9  # correctly rounded: 15950000000 ns -> 15.95 s, as logged
                        if self.last_time is None or t > self.last_time:
                            self.last_time = t
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
                        yield topic, msg
                    elif isinstance(record, Footer):
                        complete = True
            except Exception as exc:  # noqa: BLE001 - a cut-off file ends in a partial record
                if not channels:
                    raise LogError(f"{self.path}: not an MCAP run log ({type(exc).__name__}: {exc})") from None
                self.stop_reason = f"{type(exc).__name__}: {exc}" if str(exc) else type(exc).__name__
        self.truncated = not complete
        if self.truncated and not self.stop_reason:
            self.stop_reason = "no footer"
