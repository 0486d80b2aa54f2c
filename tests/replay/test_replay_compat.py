"""A log written by earlier code (main at 2f4c78c, before the input record's writer
was reworked) still reads and replays exactly.

``data/ref_2f4c78c_cut.mcap``: the first 300 kB of ``maris sim
missions/maris_pipe_recovery.yaml --scenario pool_fixed --seed 1`` as that code
wrote it (230 base steps, the file cut short as by a killed run)."""

from __future__ import annotations

from pathlib import Path

from mission.replay.rawlog import RawLog
from mission.replay.run import replay_log

FIXTURE = Path(__file__).parent / "data" / "ref_2f4c78c_cut.mcap"


def test_earlier_log_reads():
    steps = RawLog(FIXTURE).steps()
    assert [s["step"] for s in steps] == list(range(230))
    calls = {r["call"] for s in steps for r in s["reads"]}
    assert {"clock.now", "vehicle.navigation", "arm.joint_state"} <= calls
    assert all(c["call"] for s in steps for c in s["commands"])


def test_earlier_log_replays_identically(tmp_path):
    log = tmp_path / "old.mcap"
    log.write_bytes(FIXTURE.read_bytes())
    report = replay_log(log)
    assert report.comparison.identical
    assert report.steps == 230 and report.log_truncated
