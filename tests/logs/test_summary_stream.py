"""`maris log summary` streams the log: the same summary as from a log read
into memory, and memory that does not grow with the log's length (soak)."""

from __future__ import annotations

import subprocess
import sys
import tracemalloc
from pathlib import Path

from mission.logs.reader import read_log
from mission.logs.summary import summarize, summarize_file

from .conftest import write_synthetic_log

ROOT = Path(__file__).resolve().parents[2]


def test_streamed_summary_equals_the_in_memory_one(synthetic_log) -> None:  # noqa: ANN001
    streamed, stream = summarize_file(synthetic_log)
    assert not stream.truncated and streamed == summarize(read_log(synthetic_log))


def test_streamed_summary_of_a_log_cut_short(tmp_path) -> None:  # noqa: ANN001
    path = tmp_path / "cut.mcap"
    write_synthetic_log(path, seconds=20.0)
    data = path.read_bytes()
    path.write_bytes(data[: len(data) * 2 // 3])
    s, stream = summarize_file(path)
    assert stream.truncated and s["truncated"] and s["outcome"] == "incomplete (log cut short)"
    assert s == summarize(read_log(path))


def long_log(path: Path, steps: int) -> Path:
    """A run log of ``steps`` 100 Hz steps (command every step, KCL and margins at 10 Hz)."""
    from mission.logs.writer import RunLogWriter

    w = RunLogWriter(path)
    w.write("/run/config", 0.0, {"mission_name": "soak"})
    kcl = {"action": "survey", "tasks": {f"task{i}": {"activation": [1.0] * 3, "error": [0.1] * 3, "reference": [0.0] * 3}
                                         for i in range(6)}}
    for k in range(steps):
        t = k * 0.01
        w.write("/vehicle/command", t, {"body_velocity": [0.1, 0.0, 0.0, 0.0, 0.0, 0.01]})
        if k % 10 == 0:
            kcl["action"] = "survey" if (k // 3000) % 2 == 0 else "hold"
            w.write("/kcl", t, kcl)
            w.write("/safety/margins", t, {"margins": {"depth_m": 1.0 + (k % 77) * 0.01}})
    w.write("/run/result", steps * 0.01, {"outcome": "succeeded", "duration_s": steps * 0.01, "metrics": {}})
    w.close()
    return path


def peak_bytes(path: Path) -> tuple[int, dict]:
    tracemalloc.start()
    try:
        s, _ = summarize_file(path)
        return tracemalloc.get_traced_memory()[1], s
    finally:
        tracemalloc.stop()


def test_summary_memory_does_not_grow_with_the_log(tmp_path) -> None:  # noqa: ANN001
    short = long_log(tmp_path / "short.mcap", 6_000)  # 1 simulated minute
    long = long_log(tmp_path / "long.mcap", 24_000)  # 4 simulated minutes: 4 times the messages
    assert long.stat().st_size > 3.5 * short.stat().st_size
    peak_short, s_short = peak_bytes(short)
    peak_long, s_long = peak_bytes(long)
    assert len(s_long["actions"]) == 8 and s_long["duration_s"] == 240.0 and s_long["outcome"] == "succeeded"
    assert peak_long < 1.3 * peak_short + 64_000, (peak_short, peak_long)  # flat, not 4x
    assert peak_long < 0.5 * long.stat().st_size  # and far below the file (a full read holds every message)


def test_log_summary_command_streams(tmp_path) -> None:  # noqa: ANN001
    path = tmp_path / "s.mcap"
    write_synthetic_log(path)
    res = subprocess.run([sys.executable, "-m", "mission.cli", "log", "summary", str(path)], cwd=ROOT,
                         capture_output=True, text=True, timeout=60)
    assert res.returncode == 0 and "outcome:   succeeded" in res.stdout and "faults (1):" in res.stdout
