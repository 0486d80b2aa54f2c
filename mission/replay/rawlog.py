"""A run log as raw JSON bytes per topic, decoded on demand.

A replay compares two logs written by the same encoder, which is exact and
deterministic (:mod:`mission.replay.codec`): equal bytes are equal messages,
bit for bit, so only messages whose bytes differ are decoded (orjson, whose
number parsing is exact too). Reads the file sequentially like
:func:`mission.logs.reader.read_log`, so a file cut short yields everything up
to its last complete chunk.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import orjson
from mcap.records import Channel, Footer, Message, Metadata
from mcap.stream_reader import StreamReader

from mission.logs.reader import LogError
from mission.replay.schema import record_steps


class RawLog:
    """Messages of one MCAP run log by topic, in log order, as bytes."""

    def __init__(self, path: str | Path) -> None:
        self.path = Path(path)
        self.topics: dict[str, list[bytes]] = {}
        self.truncated = True
        self.stop_reason = ""
        self._decoded: dict[str, list[dict]] = {}
        #: MCAP metadata records by name (``maris.run``: versions, time base...).
        self.metadata: dict[str, dict[str, str]] = {}
        channels: dict[int, str] = {}
        try:
            f = open(self.path, "rb")
        except OSError as exc:
            raise LogError(f"{self.path}: cannot open: {exc}") from None
        with f:
            try:
                for record in StreamReader(f, skip_magic=False).records:
                    if isinstance(record, Message):
                        topic = channels.get(record.channel_id)
                        if topic is not None:
                            self.topics.setdefault(topic, []).append(record.data)
                    elif isinstance(record, Channel):
                        channels[record.id] = record.topic
                    elif isinstance(record, Metadata):
                        self.metadata[record.name] = dict(record.metadata)
                    elif isinstance(record, Footer):
                        self.truncated = False
            except Exception as exc:  # noqa: BLE001 - a cut-off file ends in a partial record
                if not channels:
                    raise LogError(f"{self.path}: not an MCAP run log ({type(exc).__name__}: {exc})") from None
                self.stop_reason = f"{type(exc).__name__}: {exc}" if str(exc) else type(exc).__name__
        if self.truncated and not self.stop_reason:
            self.stop_reason = "no footer"

    def raw(self, topic: str) -> list[bytes]:
        return self.topics.get(topic, [])

    def messages(self, topic: str) -> list[dict]:
        """Decoded messages of ``topic`` (cached)."""
        out = self._decoded.get(topic)
        if out is None:
            out = []
            for data in self.raw(topic):
                try:
                    out.append(orjson.loads(data))
                except orjson.JSONDecodeError:
                    continue
            self._decoded[topic] = out
        return out

    def steps(self) -> list[dict]:
        """The input record's steps, in order (cached)."""
        out = self._decoded.get("#steps")
        if out is None:
            out = self._decoded["#steps"] = record_steps(self)
        return out

    @property
    def result(self) -> dict[str, Any] | None:
        res = self.messages("/run/result")
        return res[-1] if res else None
