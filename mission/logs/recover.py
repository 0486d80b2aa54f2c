"""Rewrite a run log cut short (``kill -9``, power loss) as a complete MCAP file.

A killed run leaves a file without its summary, index and footer, ending in a
partial record: ``maris`` reads it (:func:`mission.logs.reader.read_log` reads
sequentially and stops at the cut), but seeking readers refuse it (the ``mcap``
package's ``make_reader(...).iter_messages()`` raises, e.g.
``RecordLengthLimitExceeded`` on the garbage after the cut). :func:`recover`
streams every complete record (schemas, channels, messages, attachments,
metadata) into a new file with a proper summary, so every tool opens it.
Everything flushed before the cut is kept (the writer flushes at least every
0.5 s of wall time); the partial last chunk is lost.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from mcap.records import Attachment, Channel, DataEnd, Footer, Header, Message, Metadata, Schema
from mcap.stream_reader import StreamReader
from mcap.writer import CompressionType, Writer


@dataclass
class Recovered:
    """What :func:`recover` wrote: counts, and why reading stopped (empty: the input was complete)."""

    messages: int
    channels: int
    attachments: int
    metadata: int
    first_ns: int | None
    last_ns: int | None
    stop_reason: str


def recover(src: str | Path, dst: str | Path) -> Recovered:
    """Copy the complete records of ``src`` into a new, indexed MCAP file ``dst``."""
    src, dst = Path(src), Path(dst)
    if src.resolve() == dst.resolve():
        raise ValueError("write the recovered log to another file")
    counts = {"messages": 0, "attachments": 0, "metadata": 0}
    first = last = None
    stop = ""
    schemas: dict[int, int] = {}
    channels: dict[int, int] = {}
    pending_schemas: dict[int, Schema] = {}
    with open(src, "rb") as f, open(dst, "wb") as out:
        writer: Writer | None = None
        reader = StreamReader(f, skip_magic=False)
        try:
            for rec in reader.records:
                if isinstance(rec, Header):
                    writer = Writer(out, compression=CompressionType.ZSTD)
                    writer.start(profile=rec.profile, library=rec.library or "maris-uvms (recovered)")
                    continue
                if writer is None:
                    raise ValueError("not an MCAP file (no header)")
                if isinstance(rec, Schema):
                    pending_schemas[rec.id] = rec
                    if rec.id not in schemas:
                        schemas[rec.id] = writer.register_schema(rec.name, rec.encoding, rec.data)
                elif isinstance(rec, Channel):
                    if rec.id not in channels:
                        sid = schemas.get(rec.schema_id, 0)
                        channels[rec.id] = writer.register_channel(
                            rec.topic, rec.message_encoding, sid, dict(rec.metadata or {})
                        )
                elif isinstance(rec, Message):
                    cid = channels.get(rec.channel_id)
                    if cid is None:
                        continue
                    writer.add_message(cid, rec.log_time, rec.data, rec.publish_time, rec.sequence)
                    counts["messages"] += 1
                    first = rec.log_time if first is None else min(first, rec.log_time)
                    last = rec.log_time if last is None else max(last, rec.log_time)
                elif isinstance(rec, Attachment):
                    writer.add_attachment(rec.create_time, rec.log_time, rec.name, rec.media_type, rec.data)
                    counts["attachments"] += 1
                elif isinstance(rec, Metadata):
                    writer.add_metadata(rec.name, dict(rec.metadata))
                    counts["metadata"] += 1
                elif isinstance(rec, (DataEnd, Footer)):
                    break
        except Exception as exc:  # noqa: BLE001 - the cut: a partial record, a bad CRC, garbage
            stop = f"{type(exc).__name__}: {exc}" if str(exc) else type(exc).__name__
            if writer is None:
                raise ValueError(f"{src}: not an MCAP file ({stop})") from None
        if writer is None:
            raise ValueError(f"{src}: empty file")
        writer.finish()
    return Recovered(counts["messages"], len(channels), counts["attachments"], counts["metadata"], first, last, stop)
