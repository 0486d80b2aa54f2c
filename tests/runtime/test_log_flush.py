"""The run log's periodic flush: by itself at a write outside the loop, at the end
of a step (after its work) while the supervisor's loop runs (mission.runtime.logflush)."""

from __future__ import annotations

import time

import pytest

from mission.logs.writer import RunLogWriter
from mission.runtime.api import run_mission
from mission.runtime.logflush import LoopFlush
from mission.runtime.options import RunOptions, RunTarget

from .conftest import REFERENCE, SCENARIO


def _write_for(w: RunLogWriter, seconds: float) -> None:
    end, t = time.monotonic() + seconds, 0.0
    while time.monotonic() < end:
        t += 0.01
        w.write("/vehicle/command", t, {"body_velocity": [t, 0.0, 0.0, 0.0, 0.0, 0.0]})
        time.sleep(0.001)


def test_writes_flush_by_themselves_unless_told_not_to(tmp_path):
    w = RunLogWriter(tmp_path / "a.mcap", flush_interval_s=0.05)
    size0 = (tmp_path / "a.mcap").stat().st_size
    _write_for(w, 0.15)
    size1 = (tmp_path / "a.mcap").stat().st_size
    assert size1 > size0  # flushed at a write: the messages are in the file

    w.flush_on_write = False
    _write_for(w, 0.15)
    assert (tmp_path / "a.mcap").stat().st_size == size1  # kept in the open chunk
    assert w.flush_if_due() is True
    size2 = (tmp_path / "a.mcap").stat().st_size
    assert size2 > size1
    assert w.flush_if_due() is False  # not due again yet
    w.close()
    assert w.flush_if_due() is False  # closed: nothing to flush


def test_loop_flush_without_a_log_does_nothing():
    lf = LoopFlush(None)
    lf.start()
    lf.stop()
    assert lf.flush_if_due is None and lf.summary() is None


@pytest.mark.slow
def test_the_loop_flushes_after_the_steps_work(tmp_path, monkeypatch):
    """During the loop no write flushes; the loop's end-of-step calls do, about every
    0.5 s of wall time, each timed; writes flush by themselves again afterwards."""
    writers: list[RunLogWriter] = []
    during_loop: list[bool] = []
    original_flush, original_init = RunLogWriter.flush, RunLogWriter.__init__

    def init(self, *a, **k):
        original_init(self, *a, **k)
        writers.append(self)

    def flush(self):
        during_loop.append(not self.flush_on_write)
        original_flush(self)

    monkeypatch.setattr(RunLogWriter, "__init__", init)
    monkeypatch.setattr(RunLogWriter, "flush", flush)
    calls: list[str] = []
    original_due = RunLogWriter.flush_if_due

    def due(self):
        did = original_due(self)
        calls.append("flushed" if did else "not due")
        return did

    monkeypatch.setattr(RunLogWriter, "flush_if_due", due)
    wall0 = time.monotonic()
    result = run_mission(RunTarget(REFERENCE, scenario=SCENARIO, seed=1), RunOptions(log_path=tmp_path / "run.mcap"))
    wall = time.monotonic() - wall0
    assert result.outcome == "succeeded"
    (w,) = writers
    assert w.flush_on_write is True  # restored when the loop ended
    flushed = calls.count("flushed")
    assert len(calls) >= result.metrics["steps"] - 1  # asked at (nearly) every step
    # the reference run takes seconds: flushed every 0.5 s of it, never more often
    assert 1 <= flushed <= wall / 0.5 + 1
    assert sum(during_loop) == flushed  # every flush inside the loop was one of those
    stats = result.metrics["wall_log_flush"]
    assert stats["n"] == flushed and 0 < stats["p50_s"] <= stats["max_s"] <= stats["total_s"]
