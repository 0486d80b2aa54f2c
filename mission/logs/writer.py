"""Crash-safe MCAP writer for run logs.

Messages are JSON (``message_encoding="json"``) with the JSON schemas of
:mod:`mission.logs.channels`, so the file opens in Foxglove as is. To survive a
``SIGKILL``, the writer finishes the open chunk and flushes the file at least
every ``flush_interval_s`` of wall time (at the first write after it, or, while
the supervisor's loop runs, at the end of that step: :mod:`mission.runtime.logflush`):
a killed run loses at most that much,
and the file reads sequentially up to there (no footer/index, which
:func:`mission.logs.reader.read_log` and the ``mcap`` package's non-seeking
reader tolerate). :meth:`RunLogWriter.close` writes the summary and index for
fast seeking.

Chunks are at most ``chunk_size`` (1 MiB, the ``mcap`` package's own default)
before compression: each chunk has a fixed cost to finish beside the
compression of its bytes, so fewer, larger chunks cost less per step and make a
smaller file (``benchmarks/log_cost.py`` measures it). In real time the flush
interval, not the size, ends most chunks. A streamed reader holds about one
chunk at a time.

Beside the JSON channels, the Foxglove well-known channels of
:mod:`mission.logs.wellknown` are registered with their protobuf schemas (from
``foxglove-sdk``) and written with :meth:`RunLogWriter.write_message` (or, for
the two written at the 3D-view rate, as bytes from :mod:`mission.logs.protowire`
with :meth:`RunLogWriter.write_encoded`). MCAP
metadata records (:meth:`RunLogWriter.metadata`) and attachments
(:meth:`RunLogWriter.attach`, e.g. the URDF) go to the data section at once.

Time: an MCAP log time is ``time_offset_ns`` + the backend clock in ns. The
simulator keeps simulated time (offset 0: the run starts near 0); field runs
pass the wall-clock offset so the log shows real dates (see
:func:`mission.logs.runmeta.time_base`).
"""

from __future__ import annotations

import json
import math
import time
from pathlib import Path
from typing import IO, Any

import numpy as np
import orjson
from mcap.writer import CompressionType, Writer

from mission.logs.channels import CHANNELS, seconds_to_ns
from mission.logs.mcapfast import FastMessages
from mission.logs.wellknown import WELL_KNOWN

PROFILE = "maris"


def _default(obj: Any) -> Any:
    if isinstance(obj, np.ndarray):
        return obj.tolist()
    if isinstance(obj, (np.floating, np.integer, np.bool_)):
        return obj.item()
    if hasattr(obj, "value") and hasattr(obj, "name"):  # enums
        return obj.value
    if isinstance(obj, (set, tuple)):
        return list(obj)
    return str(obj)


def _finite_only(obj: Any) -> Any:
    """Copy of ``obj`` with non-finite floats replaced by None (strict JSON)."""
    if isinstance(obj, float):
        return obj if math.isfinite(obj) else None
    if isinstance(obj, dict):
        return {str(k): _finite_only(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [_finite_only(v) for v in obj]
    if isinstance(obj, np.ndarray):
        return _finite_only(obj.tolist())
    if isinstance(obj, (np.floating, np.integer, np.bool_)):
        return _finite_only(obj.item())
    return obj


_ORJSON_OPTIONS = orjson.OPT_SERIALIZE_NUMPY | orjson.OPT_NON_STR_KEYS


def encode_json(msg: Any) -> bytes:
    """Strict JSON bytes of ``msg`` (numpy values converted, NaN/inf -> null).

    orjson does the work (much faster than :mod:`json`, which matters at a few
    thousand messages per wall second); it writes non-finite floats as null."""
    try:
        return orjson.dumps(msg, default=_default, option=_ORJSON_OPTIONS)
    except (TypeError, orjson.JSONEncodeError):
        return json.dumps(_finite_only(msg), default=_default, allow_nan=False, separators=(",", ":")).encode()


class RunLogWriter:
    """One MCAP run log. Use :meth:`write` (topic from ``CHANNELS``, time in s)."""

    def __init__(
        self,
        path: str | Path,
        *,
        flush_interval_s: float = 0.5,
        chunk_size: int = 1024 * 1024,
        compression: str = "lz4",
        live: Any = None,
        time_offset_ns: int = 0,
    ) -> None:
        """``live``: optional :class:`mission.logs.live.LiveServer` that also gets
        every message (closed with the writer). ``time_offset_ns``: added to the
        backend clock (ns) to make log times (0: simulated time)."""
        self.path = Path(path)
        self.path.parent.mkdir(parents=True, exist_ok=True)
        self._file: IO[bytes] = open(self.path, "wb")
        comp = {"lz4": CompressionType.LZ4, "zstd": CompressionType.ZSTD, "none": CompressionType.NONE}[compression]
        self._writer = Writer(self._file, chunk_size=chunk_size, compression=comp)
        self._writer.start(profile=PROFILE, library="maris-uvms")
        self._channel_ids: dict[str, int] = {}
        self._sequence = 0
        self._flush_interval = flush_interval_s
        self._last_flush = time.monotonic()
        #: Whether a write flushes when the interval is over (the default). The supervisor's
        #: loop turns it off while it runs and calls :meth:`flush_if_due` once per step
        #: instead, after the step's work: a flush (the chunk compressed and written)
        #: then never lands inside a step's work.
        self.flush_on_write = True
        self.closed = False
        self.message_count = 0
        self.live = live
        self.time_offset_ns = int(time_offset_ns)
        for topic, (name, schema) in CHANNELS.items():
            schema_id = self._writer.register_schema(name=name, encoding="jsonschema", data=json.dumps(schema).encode())
            self._channel_ids[topic] = self._writer.register_channel(
                topic=topic, message_encoding="json", schema_id=schema_id
            )
        schema_ids: dict[str, int] = {}
        for topic, cls in WELL_KNOWN.items():
            sch = cls.get_schema()
            if sch.name not in schema_ids:
                schema_ids[sch.name] = self._writer.register_schema(
                    name=sch.name, encoding=sch.encoding, data=bytes(sch.data)
                )
            self._channel_ids[topic] = self._writer.register_channel(
                topic=topic, message_encoding=sch.encoding, schema_id=schema_ids[sch.name]
            )
        self._writer.flush()
        #: The per-message path (the ``mcap`` writer's own ``add_message`` when the fast one
        #: does not apply to the installed ``mcap`` version).
        self._fast = FastMessages.attach(self._writer, chunk_size)

    def log_time_ns(self, t: float) -> int:
        """MCAP log time (ns) of backend time ``t`` (s)."""
        return seconds_to_ns(t) + self.time_offset_ns

    def write(self, topic: str, t: float, msg: dict) -> None:
        """Log ``msg`` (a dict; ``t`` is added) on ``topic`` at backend time ``t`` (s)."""
        if self.closed:
            return
        msg["t"] = t
        self._add(topic, seconds_to_ns(t) + self.time_offset_ns, encode_json(msg))

    def write_message(self, topic: str, ns: int, msg: Any) -> None:
        """Log a ``foxglove-sdk`` message object on a well-known ``topic`` at log time
        ``ns`` (from :meth:`log_time_ns`), protobuf encoded."""
        if not self.closed:
            self._add(topic, ns, msg.encode())

    def write_encoded(self, topic: str, ns: int, data: bytes) -> None:
        """Log protobuf bytes already encoded for a well-known ``topic`` (its schema's
        message, e.g. from :mod:`mission.logs.protowire`) at log time ``ns``."""
        if not self.closed:
            self._add(topic, ns, data)

    def _add(self, topic: str, ns: int, data: bytes) -> None:
        self._sequence += 1
        if self._fast is not None:
            self._fast.add(self._channel_ids[topic], ns, data, self._sequence)
        else:
            self._writer.add_message(
                self._channel_ids[topic], log_time=ns, data=data, publish_time=ns, sequence=self._sequence
            )
        if self.live is not None:
            self.live.publish(topic, ns, data)
        self.message_count += 1
        if self.flush_on_write and time.monotonic() - self._last_flush >= self._flush_interval:
            self.flush()

    def flush_if_due(self) -> bool:
        """:meth:`flush` if the flush interval is over since the last one; whether it did."""
        if not self.closed and time.monotonic() - self._last_flush >= self._flush_interval:
            self.flush()
            return True
        return False

    def metadata(self, name: str, values: dict[str, Any]) -> None:
        """An MCAP metadata record ``name`` (values become strings; dicts/lists as JSON)."""
        if self.closed:
            return
        flat = {str(k): v if isinstance(v, str) else encode_json(v).decode() for k, v in values.items()}
        self._writer.add_metadata(name, flat)

    def attach(self, name: str, media_type: str, data: bytes, t: float) -> None:
        """An MCAP attachment (a file: the URDF, the mission) stamped at backend time ``t``."""
        if self.closed:
            return
        ns = self.log_time_ns(t)
        self._writer.add_attachment(create_time=ns, log_time=ns, name=name, media_type=media_type, data=data)

    def flush(self) -> None:
        """Finish the open chunk and push everything to the OS (survives SIGKILL)."""
        if self.closed:
            return
        if self._fast is not None:
            self._fast.materialize()
        self._writer.flush()
        self._last_flush = time.monotonic()

    def close(self) -> None:
        """Write the summary/index and close the file. Idempotent."""
        if self.closed:
            return
        self.closed = True
        try:
            if self._fast is not None:
                self._fast.materialize()
            self._writer.finish()
        finally:
            self._file.close()
            if self.live is not None:
                self.live.close()

    def __enter__(self) -> RunLogWriter:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
