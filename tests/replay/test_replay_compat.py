"""A log written by earlier code (main at 2f4c78c, before the input record's writer
was reworked) still reads and replays.

``data/ref_2f4c78c_cut.mcap``: the first 300 kB of ``maris sim
missions/maris_pipe_recovery.yaml --scenario pool_fixed --seed 1`` as that code
wrote it (230 base steps, the file cut short as by a killed run), on the Intel
Xeon development machine of that day. Replayed there it was identical bit for
bit; on another CPU numpy's and OpenBLAS's kernels may round the last bit
differently (on an AMD EPYC with AVX-512 one logged error norm differs by one
ulp), so it is compared as docs/replay.md says for logs from another machine:
numbers within ``--tolerance 1e-9``, times, decisions and texts exactly. Exact
replay on the machine that wrote a log is checked by tests/runtime/test_replay_runs.py."""

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


def test_earlier_log_replays_within_rounding(tmp_path):
    log = tmp_path / "old.mcap"
    log.write_bytes(FIXTURE.read_bytes())
    report = replay_log(log, tolerance=1e-9)
    assert report.comparison.identical, report.comparison.first and report.comparison.first.describe()
    assert report.steps == 230 and report.log_truncated
    # the log does not say which CPU wrote it: the report says what that may mean
    assert any("which CPU wrote it" in note for note in report.notes)
