"""`maris log summary` streams the log: the same summary as from a log read
into memory, and memory that does not grow with the log's length (soak)."""

from __future__ import annotations

import subprocess
import sys
import tracemalloc
from pathlib import Path

import pytest

from mission.logs.reader import read_log
from mission.logs.summary import summarize, summarize_file
from mission.runtime.options import RunOptions, RunTarget

from .conftest import write_synthetic_log

ROOT = Path(__file__).resolve().parents[2]


def test_streamed_summary_equals_the_in_memory_one(synthetic_log) -> None:  # noqa: ANN001
    streamed, stream = summarize_file(synthetic_log)
    assert not stream.truncated and streamed == summarize(read_log(synthetic_log))


def test_streamed_summary_of_a_log_cut_short(tmp_path) -> None:  # noqa: ANN001
    path = tmp_path / "cut.mcap"
    write_synthetic_log(path, seconds=20.0, chunk_size=64 * 1024)  # many chunks, as a long run's log
    data = path.read_bytes()
    path.write_bytes(data[: len(data) * 2 // 3])
    s, stream = summarize_file(path)
    assert stream.truncated and s["truncated"] and s["outcome"] == "incomplete (log cut short)"
    assert s == summarize(read_log(path))


def long_log(path: Path, steps: int) -> Path:
    """A run log of ``steps`` 100 Hz steps (command every step, KCL and margins at 10 Hz),
    in 64 KiB chunks: both test logs hold many chunks (the reader's peak is about one
    chunk, decompressed and parsed, whatever the writer's chunk size)."""
    from mission.logs.writer import RunLogWriter

    w = RunLogWriter(path, chunk_size=64 * 1024)
    w.write("/run/config", 0.0, {"mission_name": "soak"})
    kcl = {
        "action": "survey",
        "tasks": {f"task{i}": {"activation": [1.0] * 3, "error": [0.1] * 3, "reference": [0.0] * 3} for i in range(6)},
    }
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


def peak_bytes(path: Path, read=lambda p: summarize_file(p)[0]) -> tuple[int, object]:  # noqa: ANN001
    """(peak traced allocation in bytes, result) of ``read(path)``."""
    read(path)  # once untraced: lazy imports and caches do not count
    tracemalloc.start()
    try:
        out = read(path)
        return tracemalloc.get_traced_memory()[1], out
    finally:
        tracemalloc.stop()


@pytest.mark.slow
def test_summary_memory_does_not_grow_with_the_log(tmp_path) -> None:  # noqa: ANN001
    short = long_log(tmp_path / "short.mcap", 6_000)  # 1 simulated minute
    long = long_log(tmp_path / "long.mcap", 24_000)  # 4 simulated minutes: 4 times the messages
    assert long.stat().st_size > 3.5 * short.stat().st_size
    peak_short, s_short = peak_bytes(short)
    peak_long, s_long = peak_bytes(long)
    assert len(s_long["actions"]) == 8 and s_long["duration_s"] == 240.0 and s_long["outcome"] == "succeeded"
    assert peak_long < 1.3 * peak_short + 64_000, (peak_short, peak_long)  # flat, not 4x
    # and far below a full read, which holds every decoded message (the file itself is
    # compressed, so its size says little: a chunk's decompression buffer dominates the peak)
    peak_full, _ = peak_bytes(long, read_log)
    assert peak_long < 0.2 * peak_full, (peak_long, peak_full)


@pytest.mark.slow
def test_log_summary_command_streams(tmp_path) -> None:  # noqa: ANN001
    path = tmp_path / "s.mcap"
    write_synthetic_log(path)
    res = subprocess.run(
        [sys.executable, "-m", "mission.cli", "log", "summary", str(path)],
        cwd=ROOT,
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert res.returncode == 0 and "outcome:   succeeded" in res.stdout and "faults (1):" in res.stdout


#: A short mission (descend, hold, wait: ~9 s of backend time).
SHORT_MISSION = """\
version: 1
name: field_summary
rates: {tree_hz: 10, vehicle_hz: 10, arm_hz: 100}
safety:
  max_depth_m: 5.0
  min_altitude_m: 0.3
  max_duration_s: 60
  geofence: {north_m: [-5, 30], east_m: [-10, 15], down_m: [0, 5]}
tree:
  sequence:
    name: Short field run
    children:
      - action: {name: Descend, run: survey, targets: {vehicle_goal: {down_m: 2.3}, tolerance_m: 0.3}, timeout_s: 30}
      - action: {name: Hold, run: hold, until: converged, timeout_s: 10}
      - wait: {duration_s: 5}
abort:
  action: {name: Hold still, run: hold, until: converged, timeout_s: 10}
"""


def field_log(tmp_path: Path):  # noqa: ANN201
    """(RunResult, log path) of a run logged with the field time base by the real
    runtime: a backend passed in, as `maris run` passes its drivers, so MCAP log
    times are the wall clock (``time_offset_ns`` in ``maris.run``) while every
    message's ``t`` is backend time (here the simulator's, from 0)."""
    from mission.runtime.api import run_mission
    from sim_backend import SimBackend, load_scenario

    mission = tmp_path / "short.yaml"
    mission.write_text(SHORT_MISSION)
    log = tmp_path / "field.mcap"
    return run_mission(
        RunTarget(mission, backend=SimBackend(load_scenario("pool_fixed"), 1)), RunOptions(log_path=log)
    ), log


@pytest.mark.slow
def test_summary_of_a_field_log_complete_and_cut_short_is_in_run_time(tmp_path) -> None:  # noqa: ANN001
    """`maris log summary` on a field log: durations and times from the run start, not
    from the wall-clock log times (~1.8e9 s); the same as the in-memory summary."""
    from mission.logs.stream import LogStream

    result, path = field_log(tmp_path)
    assert result.outcome == "succeeded", result.failure_cause
    stream = LogStream(path)
    for _ in stream:
        pass
    assert stream.time_offset_ns > 1_600_000_000 * 10**9  # the log really has the wall-clock time base
    assert result.duration_s <= stream.last_time < result.duration_s + 0.5  # backend time of the last message
    s, _ = summarize_file(path)
    assert s["duration_s"] == result.duration_s > 5.0 and s == summarize(read_log(path))
    assert [a for _, a in s["actions"]] == ["survey", "hold"]
    data = path.read_bytes()
    path.write_bytes(data[: len(data) * 3 // 4])  # killed before its end
    s, stream = summarize_file(path)
    assert stream.truncated and s["outcome"] == "incomplete (log cut short)"
    assert 0.3 * result.duration_s < s["duration_s"] < result.duration_s, s["duration_s"]
    assert all(0.0 <= t <= s["duration_s"] for t, _ in s["actions"] + s["supervisor_states"])
    res = subprocess.run(
        [sys.executable, "-m", "mission.cli", "log", "summary", str(path)],
        cwd=ROOT,
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert res.returncode == 0 and f"duration:  {s['duration_s']:.1f} s   [log cut short]" in res.stdout, res.stdout
