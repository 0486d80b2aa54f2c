"""Cost of the mission layer: loading + checking a mission file, compiling it,
and one behaviour-tree tick (the supervisor ticks at ~10 Hz).

* load: ``load_mission`` of each shipped mission (YAML with positions, every
  check; the actions file is cached after the first load, as in a process that
  loads several missions);
* compile: ``compile_mission`` + ``compile_abort``;
* tick: one ``tick_once`` of the MARIS tree while its survey leaf runs on the
  simulator (reads navigation and the detector, follows waypoints), with a
  recording controller (the KCL itself is measured by tpik_pass.py).

CPU time of this process, median over repetitions. Last line:
``mission_tree load_ms=... compile_ms=... tick_us=...``.

Usage: ``python benchmarks/mission_tree.py [--reps 50]``
"""

from __future__ import annotations

import argparse
import statistics
import time
from pathlib import Path

import numpy as np

from behaviours.context import EventList, MissionBlackboard
from mission.compiler import compile_abort, compile_mission
from mission.loader import load_mission
from sim_backend import SimBackend, load_scenario

MISSIONS = Path(__file__).resolve().parents[1] / "missions"


class _Controller:
    """Accepts the calls leaves make; ``transport`` converges at once, so the
    tree reaches the survey leaf and stays there (its pattern is long)."""

    def set_action(self, name, t):
        self.action = name

    def set_targets(self, **kw):
        pass

    def stop(self, t):
        pass

    def telemetry(self):
        return {
            "action": getattr(self, "action", None),
            "stopped": False,
            "transition_progress": 1.0,
            "convergence": 0.0 if getattr(self, "action", None) == "transport" else 1.0,
            "fault": False,
        }


class _Ctx:
    def __init__(self, sim, mission):
        self.sim, self.devices, self.controller = sim, sim.devices, _Controller()
        self.blackboard = MissionBlackboard.for_mission(mission)
        self.events = EventList()

    def now(self):
        return self.sim.clock.now()

    def stop_motion(self):
        pass


def _median_ms(fn, reps: int) -> float:
    times = []
    for _ in range(reps):
        t0 = time.process_time()
        fn()
        times.append(time.process_time() - t0)
    return 1e3 * statistics.median(times)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--reps", type=int, default=50)
    args = ap.parse_args()
    t0 = time.process_time()
    load_mission(MISSIONS / "maris_pipe_recovery.yaml")
    print(f"first load (imports kcl, reads the actions file and URDF): {1e3 * (time.process_time() - t0):.1f} ms")
    load_ms = {}
    for path in sorted(MISSIONS.glob("*.yaml")):
        load_ms[path.name] = _median_ms(lambda p=path: load_mission(p), args.reps)
        print(f"load {path.name}: {load_ms[path.name]:.2f} ms")
    mission = load_mission(MISSIONS / "maris_pipe_recovery.yaml")
    sim = SimBackend(load_scenario("pool_clear"), seed=1)
    sim.open()
    ctx = _Ctx(sim, mission)
    compile_ms = _median_ms(lambda: (compile_mission(mission, ctx), compile_abort(mission, ctx)), args.reps)
    print(f"compile main + abort: {compile_ms:.3f} ms")
    root = compile_mission(mission, ctx)
    ticks = []
    for _ in range(20 * args.reps):
        sim.advance(0.1)
        t0 = time.process_time()
        root.tick_once()
        ticks.append(time.process_time() - t0)
    tip = root.tip().name if root.tip() else "-"
    tick_us = 1e6 * statistics.median(ticks)
    print(f"tick (running leaf: {tip}): median {tick_us:.0f} us, p95 {1e6 * float(np.percentile(ticks, 95)):.0f} us")
    print(
        f"mission_tree load_ms={load_ms['maris_pipe_recovery.yaml']:.2f} compile_ms={compile_ms:.3f} tick_us={tick_us:.0f}"
    )


if __name__ == "__main__":
    main()
