"""Memory and time of ``maris log summary`` on a long run log: the streamed
summary (:func:`mission.logs.summary.summarize_file`) against reading the whole
log first (:func:`mission.logs.reader.read_log` + ``summarize``, what the command
did before).

The log is synthetic but shaped like a field run's, written by the real writer:
per simulated second 20 device samples (navigation, commands, arm state and
command), 10 KCL messages with 10 tasks, 10 margin messages, 10 ground-truth
messages; an action switch every 30 s. Peak memory is Python's allocations
during the summary (``tracemalloc``), time is wall time (noisy on a shared
machine). Last line: ``log_summary minutes=... file_mb=... stream_peak_mb=...
full_peak_mb=... stream_s=... full_s=...``.

Usage: ``python benchmarks/log_summary.py [--minutes 20] [--skip-full]``
"""

from __future__ import annotations

import argparse
import tempfile
import time
import tracemalloc
from pathlib import Path

from mission.logs.reader import read_log
from mission.logs.summary import summarize, summarize_file
from mission.logs.writer import RunLogWriter


def write_log(path: Path, minutes: float) -> None:
    w = RunLogWriter(path)
    w.write("/run/config", 0.0, {"mission_name": "bench"})
    tasks = {
        f"task{i}": {"activation": [1.0] * 3, "error": [0.01] * 3, "reference": [0.0] * 3, "note": ""}
        for i in range(10)
    }
    steps = int(minutes * 60 * 20)
    for k in range(steps):
        t = k / 20.0
        w.write(
            "/vehicle/navigation",
            t,
            {
                "position": [t * 0.01, 0.0, 3.0],
                "attitude": [0.0, 0.0, 0.1],
                "body_velocity": [0.1, 0.0, 0.0, 0.0, 0.0, 0.01],
                "depth": 3.0,
                "altitude": 2.0,
            },
        )
        w.write("/vehicle/command", t, {"body_velocity": [0.1, 0.0, 0.0, 0.0, 0.0, 0.01]})
        w.write("/arm/state", t, {"position": [0.1] * 7, "velocity": [0.0] * 7, "current": [0.3] * 7})
        w.write("/arm/command", t, {"velocity": [0.0] * 7})
        if k % 2 == 0:
            w.write("/kcl", t, {"action": ("survey", "grasp", "transport")[int(t // 30) % 3], "tasks": tasks})
            w.write("/safety/margins", t, {"margins": {"depth_m": 1.0, "geofence_m": 2.0 + (k % 13) * 0.1}})
            w.write("/ground_truth", t, {"tool_to_target_m": 1.0 / (1.0 + t), "grasp": "none"})
    w.write("/run/result", steps / 20.0, {"outcome": "succeeded", "duration_s": steps / 20.0, "metrics": {}})
    w.close()


def measure(fn) -> tuple[float, float]:  # noqa: ANN001
    tracemalloc.start()
    t0 = time.perf_counter()
    fn()
    dt = time.perf_counter() - t0
    peak = tracemalloc.get_traced_memory()[1] / 1e6
    tracemalloc.stop()
    return peak, dt


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--minutes", type=float, default=20.0, help="simulated minutes of log (default 20)")
    ap.add_argument("--skip-full", action="store_true", help="do not measure the full read (slow, big)")
    args = ap.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "long.mcap"
        write_log(path, args.minutes)
        size = path.stat().st_size / 1e6
        print(f"log: {args.minutes:g} simulated minutes, {size:.1f} MB")
        s_peak, s_time = measure(lambda: summarize_file(path))
        print(f"streamed summary:  peak {s_peak:8.1f} MB  {s_time:6.2f} s")
        f_peak, f_time = float("nan"), float("nan")
        if not args.skip_full:
            f_peak, f_time = measure(lambda: summarize(read_log(path)))
            print(f"full read + summary: peak {f_peak:6.1f} MB  {f_time:6.2f} s")
    print(
        f"log_summary minutes={args.minutes:g} file_mb={size:.1f} stream_peak_mb={s_peak:.2f} "
        f"full_peak_mb={f_peak:.1f} stream_s={s_time:.2f} full_s={f_time:.2f}"
    )


if __name__ == "__main__":
    main()
