"""A cheaper per-message path into the ``mcap`` package's chunked :class:`~mcap.writer.Writer`.

The ``mcap`` writer is pure Python: ``Writer.add_message`` builds a ``Message``
dataclass, updates the statistics and the chunk's message index, and writes the
record field by field (a ``struct.pack`` and a buffer write per field, a seek
back to patch the record length), then each chunk's message index again one
``struct.pack`` per number. A run log holds ~2 messages per 10 ms base step, so
this fixed cost was a large part of what logging costs the supervisor loop.

:class:`FastMessages` does the same bookkeeping and writes the same bytes (one
``struct.pack`` for the record head, one for each message index) into the
writer's open chunk; the writer itself still closes chunks, compresses them,
writes the indexes, statistics and summary. It relies on the writer's internal
attributes (those of ``mcap`` 1.1 - 1.x): :meth:`FastMessages.attach` checks
they are there and returns None otherwise (the writer's own ``add_message`` is
then used). ``tests/logs/test_mcapfast.py`` checks that both paths give
byte-identical files.
"""

from __future__ import annotations

import struct
from typing import Any

from mcap._chunk_builder import ChunkBuilder
from mcap.data_stream import RecordBuilder
from mcap.opcode import Opcode
from mcap.records import MessageIndex

#: Message record head: opcode, record length, channel id, sequence, log time, publish time.
_HEAD = struct.Struct("<BQHIQQ")
_HEAD_LEN = 22  # the fields after the record length: 2 + 4 + 8 + 8


class _Index(MessageIndex):
    """A chunk's message index for one channel, written with one ``struct.pack``."""

    def write(self, stream: RecordBuilder) -> None:
        recs = self.records
        n = len(recs)
        flat = [x for rec in recs for x in rec]
        stream.write(struct.pack(f"<BQHI{2 * n}Q", Opcode.MESSAGE_INDEX, 6 + 16 * n, self.channel_id, 16 * n, *flat))


class FastMessages:
    """Appends messages to ``writer``'s open chunk (see the module docstring)."""

    def __init__(self, writer: Any, chunk_size: int) -> None:
        self._writer = writer
        self._stats = writer._Writer__statistics  # noqa: SLF001 - see the module docstring
        self._chunk: ChunkBuilder = writer._Writer__chunk_builder  # noqa: SLF001
        self._finalize = writer._Writer__finalize_chunk  # noqa: SLF001
        self._chunk_size = chunk_size

    @classmethod
    def attach(cls, writer: Any, chunk_size: int) -> "FastMessages | None":
        """The fast path for ``writer`` (chunked, the internals this module knows), else None."""
        chunk = getattr(writer, "_Writer__chunk_builder", None)
        stats = getattr(writer, "_Writer__statistics", None)
        if (type(chunk) is not ChunkBuilder or stats is None or not callable(getattr(writer, "_Writer__finalize_chunk", None))
                or not hasattr(chunk, "record_writer") or not hasattr(chunk.record_writer, "_buffer")
                or getattr(writer, "_Writer__chunk_size", None) != chunk_size
                or not all(hasattr(stats, a) for a in ("message_count", "message_start_time", "message_end_time",
                                                        "channel_message_counts"))):
            return None
        return cls(writer, chunk_size)

    def add(self, channel_id: int, ns: int, data: bytes, sequence: int) -> None:
        """What ``Writer.add_message(channel_id, log_time=ns, data=data, publish_time=ns,
        sequence=sequence)`` does, for a chunked writer."""
        st = self._stats
        if st.message_count == 0:
            st.message_start_time = ns
        elif ns < st.message_start_time:
            st.message_start_time = ns
        if ns > st.message_end_time:
            st.message_end_time = ns
        st.channel_message_counts[channel_id] += 1
        st.message_count += 1
        cb = self._chunk
        if cb.num_messages == 0:
            cb.message_start_time = ns
        elif ns < cb.message_start_time:
            cb.message_start_time = ns
        if ns > cb.message_end_time:
            cb.message_end_time = ns
        buf = cb.record_writer._buffer  # noqa: SLF001 - a new BytesIO after each chunk
        index = cb.message_indices.get(channel_id)
        if index is None:
            index = cb.message_indices[channel_id] = _Index(channel_id=channel_id, records=[])
        offset = buf.tell()
        index.records.append((ns, offset))
        cb.num_messages += 1
        buf.write(_HEAD.pack(Opcode.MESSAGE, _HEAD_LEN + len(data), channel_id, sequence, ns, ns))
        buf.write(data)
        if offset + 31 + len(data) > self._chunk_size:
            self._finalize()
