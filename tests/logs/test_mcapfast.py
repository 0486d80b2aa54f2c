"""The writer's fast message path writes exactly what ``mcap``'s own ``add_message`` writes."""

from __future__ import annotations

import random

import pytest
from mcap.reader import make_reader

from mission.logs.writer import RunLogWriter

pytestmark = pytest.mark.slow


def _write(path, fast: bool, *, chunk_size: int) -> None:
    w = RunLogWriter(path, chunk_size=chunk_size, flush_interval_s=1e9)
    assert w._fast is not None  # the installed mcap version has the internals the fast path uses
    if not fast:
        w._fast = None
    rng = random.Random(3)
    t = 5.0
    for i in range(3000):
        t += rng.choice((0.0, 0.01, -0.02))  # equal and earlier times too
        topic = rng.choice(("/kcl", "/vehicle/navigation", "/events", "/replay/steps", "/arm/state"))
        w.write(topic, t, {"i": i, "pad": "x" * rng.randrange(0, 3000)})
        if i in (10, 11, 1500):  # a flush finishes the chunk (also an empty one)
            w.flush()
    w.close()


def test_fast_path_is_byte_identical(tmp_path):
    for chunk_size in (64 * 1024, 1000):
        fast, slow = tmp_path / f"fast{chunk_size}.mcap", tmp_path / f"slow{chunk_size}.mcap"
        _write(fast, True, chunk_size=chunk_size)
        _write(slow, False, chunk_size=chunk_size)
        assert fast.read_bytes() == slow.read_bytes()
        with open(fast, "rb") as f:
            reader = make_reader(f)
            assert sum(1 for _ in reader.iter_messages()) == 3000
            assert reader.get_summary().statistics.message_count == 3000
