"""A cheaper per-message path into the ``mcap`` package's chunked :class:`~mcap.writer.Writer`.

The ``mcap`` writer is pure Python: ``Writer.add_message`` builds a ``Message``
dataclass, updates the statistics and the chunk's message index, and writes the
record field by field (a ``struct.pack`` and a buffer write per field, a seek
back to patch the record length), then each chunk's message index again one
``struct.pack`` per number. A run log holds a few messages per base step, so
this fixed cost is a large part of what logging costs the supervisor loop.

:class:`FastMessages` does the same bookkeeping and writes the same bytes (one
``struct.pack`` for the record head, one for each message index) into the
writer's open chunk; the writer itself still closes chunks, compresses them,
writes the indexes, statistics and summary. A message added is only held (a
tuple appended to a list); the held ones go into the chunk together
(:meth:`FastMessages.materialize`) when the chunk is full or before the writer
flushes or finishes, which :class:`mission.logs.writer.RunLogWriter` does. The
file is the same; what changes is when the work is done: a message written on
its own amid other work meets the interpreter's caches cold, while the messages
of a chunk put into it in one loop cost less each (``benchmarks/log_cost.py``
measures both). In ``maris run`` that loop falls in the log's flush after a
step's work (:mod:`mission.runtime.logflush`). It relies on the writer's internal
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
        #: Messages added since the last :meth:`materialize`: (channel id, sequence, log time ns, data).
        self._pending: list[tuple[int, int, int, bytes]] = []
        #: The open chunk's record bytes with them (31 of head each, plus the data).
        self._size = 0

    @classmethod
    def attach(cls, writer: Any, chunk_size: int) -> FastMessages | None:
        """The fast path for ``writer`` (chunked, the internals this module knows), else None."""
        chunk = getattr(writer, "_Writer__chunk_builder", None)
        stats = getattr(writer, "_Writer__statistics", None)
        if (
            type(chunk) is not ChunkBuilder
            or stats is None
            or not callable(getattr(writer, "_Writer__finalize_chunk", None))
            or not hasattr(chunk, "record_writer")
            or not hasattr(chunk.record_writer, "_buffer")
            or getattr(writer, "_Writer__chunk_size", None) != chunk_size
            or not all(
                hasattr(stats, a)
                for a in ("message_count", "message_start_time", "message_end_time", "channel_message_counts")
            )
        ):
            return None
        return cls(writer, chunk_size)

    def add(self, channel_id: int, ns: int, data: bytes, sequence: int) -> None:
        """What ``Writer.add_message(channel_id, log_time=ns, data=data, publish_time=ns,
        sequence=sequence)`` does, for a chunked writer: the message is held, and goes
        into the open chunk with the others at :meth:`materialize`, when the chunk is
        full or before the writer flushes or finishes."""
        pending = self._pending
        if not pending:  # the open chunk's records so far (the channels and schemas, in the first)
            self._size = self._chunk.record_writer._buffer.tell()  # noqa: SLF001
        pending.append((channel_id, sequence, ns, data))
        self._size += 31 + len(data)
        if self._size > self._chunk_size:
            self.materialize()
            self._finalize()

    def materialize(self) -> None:
        """Put the held messages into the writer's open chunk (records, message index,
        statistics, chunk times), in the order they were added. Must run before the
        writer flushes or finishes (:class:`mission.logs.writer.RunLogWriter` does)."""
        pending = self._pending
        if not pending:
            return
        self._pending = []
        st = self._stats
        cb = self._chunk
        buf = cb.record_writer._buffer  # noqa: SLF001 - a new BytesIO after each chunk
        offset = buf.tell()
        indices = cb.message_indices
        counts = st.channel_message_counts
        count, start, end = st.message_count, st.message_start_time, st.message_end_time
        c_count, c_start, c_end = cb.num_messages, cb.message_start_time, cb.message_end_time
        pack, opcode = _HEAD.pack, Opcode.MESSAGE
        parts = []
        for channel_id, sequence, ns, data in pending:
            if count == 0 or ns < start:
                start = ns
            if ns > end:
                end = ns
            count += 1
            if c_count == 0 or ns < c_start:
                c_start = ns
            if ns > c_end:
                c_end = ns
            c_count += 1
            counts[channel_id] += 1
            index = indices.get(channel_id)
            if index is None:
                index = indices[channel_id] = _Index(channel_id=channel_id, records=[])
            index.records.append((ns, offset))
            n = len(data)
            parts.append(pack(opcode, _HEAD_LEN + n, channel_id, sequence, ns, ns))
            parts.append(data)
            offset += 31 + n
        buf.write(b"".join(parts))
        st.message_count, st.message_start_time, st.message_end_time = count, start, end
        cb.num_messages, cb.message_start_time, cb.message_end_time = c_count, c_start, c_end
