"""Replay speed against the dry run it replays, and the size of the input record.

Dry-runs ``missions/maris_pipe_recovery.yaml`` on the simulator with logging on
(input record included), then replays that log exactly (``maris log replay``:
the same supervisor code against a backend serving the logged readings,
writing its own log) and compares. Both speeds are simulated seconds per second
of the supervisor run, from the backend's open to its close (loading the
mission and models excluded; both runs write a log): per wall second, and per
CPU second of this process (less sensitive to other load on a shared machine).
The best of ``--repeat`` pairs is kept. Also printed: the replay's loading and
comparison times, and the log size per minute of mission with and without the
input record. Target: the replay at least as fast as the dry run.

    .venv/bin/python benchmarks/replay.py [--scenario pool_fixed] [--seed 1] [--repeat 3]

Last line: ``replay realtime_factor=<r> dry_run_realtime_factor=<d> replay_cpu_factor=<rc>
dry_run_cpu_factor=<dc> log_mb_per_min=<m> input_record_mb_per_min=<i>``.
"""

from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


class _Stamped:
    """A backend whose open/close note the wall and CPU clocks (like the replay backend's)."""

    def __init__(self, inner) -> None:  # noqa: ANN001
        self.inner = inner

    def __getattr__(self, name: str):  # noqa: ANN204
        return getattr(self.inner, name)

    def open(self) -> None:
        self.wall_open, self.cpu_open = time.perf_counter(), time.process_time()
        self.inner.open()

    def close(self) -> None:
        self.wall_close, self.cpu_close = time.perf_counter(), time.process_time()
        self.inner.close()


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--mission", default=str(ROOT / "missions" / "maris_pipe_recovery.yaml"))
    ap.add_argument("--scenario", default="pool_fixed")
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--repeat", type=int, default=3)
    args = ap.parse_args()

    from kcl.model import UvmsModel
    from mission.replay.run import replay_log
    from mission.runtime.api import run_mission
    from mission.runtime.options import RunOptions, RunTarget
    from sim_backend import SimBackend, load_scenario

    model = UvmsModel.load()
    best: dict[str, tuple[float, float]] = {}
    with tempfile.TemporaryDirectory() as tmp:
        log, bare = Path(tmp) / "run.mcap", Path(tmp) / "bare.mcap"
        run_mission(
            RunTarget(args.mission, scenario=args.scenario, seed=args.seed),
            RunOptions(log_path=bare, record_inputs=False),
        )
        bare_mb = bare.stat().st_size / 1e6
        for _ in range(args.repeat):
            sim = _Stamped(SimBackend(load_scenario(args.scenario), args.seed, model=model))
            result = run_mission(RunTarget(args.mission, backend=sim), RunOptions(log_path=log))
            report = replay_log(log)
            dur = result.duration_s
            for name, wall, cpu in (
                ("dry", sim.wall_close - sim.wall_open, sim.cpu_close - sim.cpu_open),
                ("replay", report.wall_s, report.cpu_s),
            ):
                w, c = best.get(name, (1e9, 1e9))
                best[name] = (min(w, wall), min(c, cpu))
            assert report.identical, report.comparison.first
        log_mb = log.stat().st_size / 1e6
    per_min = 60.0 / dur
    (dw, dc), (rw, rc) = best["dry"], best["replay"]
    print(
        f"mission      {Path(args.mission).name} scenario={args.scenario} seed={args.seed}, {dur:.1f} s simulated, "
        f"best of {args.repeat}"
    )
    print(f"dry run      {dw:.2f} s wall, {dc:.2f} s cpu -> {dur / dw:.1f}x real time ({dur / dc:.1f}x per cpu s)")
    print(
        f"replay       {rw:.2f} s wall, {rc:.2f} s cpu -> {dur / rw:.1f}x real time ({dur / rc:.1f}x per cpu s); "
        f"identical; last run: loading {report.setup_wall_s:.2f} s, comparison {report.compare_wall_s:.2f} s"
    )
    verdict = "met" if rc <= dc else f"MISSED: the replay takes {rc / dc:.1f}x the dry run's CPU time"
    print(f"target       replay at least as fast as the dry run (per CPU s): {verdict}")
    print(
        f"log size     {log_mb:.2f} MB = {log_mb * per_min:.1f} MB per minute of mission; without the input record "
        f"{bare_mb:.2f} MB = {bare_mb * per_min:.1f} MB/min (input record {(log_mb - bare_mb) * per_min:.1f} MB/min)"
    )
    print(
        f"replay realtime_factor={dur / rw:.1f} dry_run_realtime_factor={dur / dw:.1f} replay_cpu_factor={dur / rc:.1f} "
        f"dry_run_cpu_factor={dur / dc:.1f} log_mb_per_min={log_mb * per_min:.2f} "
        f"input_record_mb_per_min={(log_mb - bare_mb) * per_min:.2f}"
    )


if __name__ == "__main__":
    main()
