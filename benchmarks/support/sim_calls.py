"""Record every call the supervisor makes to the simulator during a dry run,
then replay them into a fresh simulator: a simulator-only instruction count of
the real workload (callgrind) and an exactness check (every reading, command
result and ground truth compared with the recorded one, then every state of
the simulator at the end).

    .venv/bin/python benchmarks/support/sim_calls.py record OUT.pkl [--scenario pool_fixed] [--seed 1]
    .venv/bin/python benchmarks/support/sim_calls.py replay OUT.pkl [--tol 0]
    .venv/bin/python benchmarks/support/sim_calls.py compare A.pkl B.pkl [--tol 0]
    .venv/bin/python benchmarks/support/sim_calls.py count OUT.pkl [--core]   # callgrind, minutes
        (MARIS_SIM_CALLS_CALLGRIND_OUT=FILE keeps callgrind's profile for callgrind_annotate)

``record`` runs ``missions/maris_pipe_recovery.yaml`` on the simulator without
a log and stores, in call order, each call of ``SimBackend.advance``,
``ground_truth``, ``truth_brief`` and ``inject`` and of every public method of the simulated
devices (vehicle, arm, gripper, detector, wrench sensor: commands, readings,
health) with its arguments and result. ``replay`` builds a fresh
``SimBackend`` of the same scenario and seed, makes the same calls and prints
the largest difference from the recorded results (0 = bit for bit; a result
of another structure counts as inf). ``compare`` checks two records of the
closed loop (before and after a change): same calls, outcome and action
switch times, and the largest difference of any command or reading. ``count`` replays twice in a process
under callgrind (the first replay warms up: not counted) and prints the
instructions per base step (per ``advance`` call: one 10 ms step of the
reference mission). ``--core`` leaves the read-only calls out of both replays
(``ground_truth``, ``health``, the detector's): about what the first perf
round counted as the simulator part (``advance``, the commands, navigation and
joint readings; here also the few gripper and wrench calls).
Last line: ``sim_instructions per_step=<n> total=<n> steps=<n> core=<0|1>``.
"""

from __future__ import annotations

import copy
import os
import pickle
import sys
from pathlib import Path
from typing import Any

sys.path.insert(0, str(Path(__file__).resolve().parent))
from call_records import command_parsers, instrument, largest_difference, run_counted  # noqa: E402

ROOT = Path(__file__).resolve().parents[2]
_CHILD = "MARIS_SIM_CALLS_CHILD"
_BACKEND = ("advance", "ground_truth", "truth_brief", "inject")
_DEVICES = {
    "vehicle": ("SimVehicle", ("arm", "disarm", "command_body_velocity", "navigation", "health")),
    "arm": ("SimArm", ("enable", "disable", "command_joint_velocity", "joint_state", "health")),
    "gripper": ("SimGripper", ("preshape", "close", "open", "stop", "state", "health")),
    "detector": ("SimDetector", ("latest", "camera_frames", "health")),
    "wrench_sensor": ("SimWrenchSensor", ("wrench", "health")),
}
#: Calls that change nothing in the simulator (left out of a ``--core`` replay).
READ_ONLY = {
    ("backend", "ground_truth"),
    ("backend", "truth_brief"),
    ("detector", "latest"),
    ("detector", "camera_frames"),
} | {(dev, "health") for dev in _DEVICES}


def record(out: Path, scenario: str, seed: int) -> None:
    sys.path.insert(0, str(ROOT))
    import sim_backend.devices as devices
    from mission.runtime.api import run_mission
    from mission.runtime.options import RunOptions, RunTarget
    from sim_backend import SimBackend

    calls: list[tuple[str, str, tuple, Any]] = []
    patched: list[tuple[type, str, Any]] = []

    def wrap(cls: type, dev: str, name: str) -> None:
        inner = getattr(cls, name)

        def wrapper(self: Any, *args: Any, **kwargs: Any) -> Any:
            assert not kwargs, (dev, name, kwargs)
            saved = copy.deepcopy(args)
            result = inner(self, *args)
            calls.append((dev, name, saved, copy.deepcopy(result)))
            return result

        patched.append((cls, name, inner))
        setattr(cls, name, wrapper)

    for name in _BACKEND:
        wrap(SimBackend, "backend", name)
    for dev, (cls_name, names) in _DEVICES.items():
        for name in names:
            wrap(getattr(devices, cls_name), dev, name)
    try:
        result = run_mission(
            RunTarget(ROOT / "missions" / "maris_pipe_recovery.yaml", scenario=scenario, seed=seed),
            RunOptions(log_path=None),
        )
    finally:
        for cls, name, inner in patched:
            setattr(cls, name, inner)
    with open(out, "wb") as fh:
        pickle.dump({"scenario": scenario, "seed": seed, "calls": calls, "result": result.to_dict()}, fh)
    kinds: dict[str, int] = {}
    for dev, name, *_rest in calls:
        kinds[f"{dev}.{name}"] = kinds.get(f"{dev}.{name}", 0) + 1
    print(f"recorded {len(calls)} calls ({kinds}); outcome {result.outcome}")


def compare(a_path: Path, b_path: Path, tol: float) -> int:
    """Two records of the closed loop (e.g. before and after a change that may
    round differently): the same calls in the same order, the same outcome and
    action switch times, and the largest difference of any argument (commands)
    or result (readings, ground truth) and of the run's metrics (but wall times)."""
    a, b = _load(a_path), _load(b_path)
    ra, rb = a["result"], b["result"]
    print(f"outcome {ra['outcome']} / {rb['outcome']}; duration {ra['duration_s']} / {rb['duration_s']}")
    same_actions = ra["actions"] == rb["actions"]
    print(f"action switches ({len(ra['actions'])}): {'identical' if same_actions else 'DIFFERENT'}")
    names_a = [(d, n) for d, n, *_r in a["calls"]]
    names_b = [(d, n) for d, n, *_r in b["calls"]]
    if names_a != names_b:
        first = next((i for i, (x, y) in enumerate(zip(names_a, names_b)) if x != y), min(len(names_a), len(names_b)))
        print(f"call sequences differ from call {first} ({len(names_a)} / {len(names_b)} calls)")
        return 1
    worst, worst_at = 0.0, None
    for i, (ca, cb) in enumerate(zip(a["calls"], b["calls"])):
        d = max(largest_difference(ca[2], cb[2]), largest_difference(ca[3], cb[3]))
        if d > worst:
            worst, worst_at = d, (i, f"{ca[0]}.{ca[1]}")
    timing = ("wall_", "realtime_factor", "phase_wall_s")  # wall-clock figures: not the simulation's
    ma, mb = ({k: v for k, v in r["metrics"].items() if not k.startswith(timing)} for r in (ra, rb))
    metrics = largest_difference(ma, mb)
    print(
        f"{len(names_a)} calls, same sequence; largest difference of an argument or result: {worst:.3g}"
        + (f" (call {worst_at[0]}, {worst_at[1]})" if worst_at else "")
        + f"; of the run metrics: {metrics:.3g}"
    )
    print(f"sim_compare max_diff={max(worst, metrics):.3g} same_actions={int(same_actions)}")
    return 0 if same_actions and ra["outcome"] == rb["outcome"] and max(worst, metrics) <= tol else 1


def _load(path: Path) -> dict:
    sys.path.insert(0, str(ROOT))
    with open(path, "rb") as fh:
        return pickle.load(fh)


def _fresh(data: dict) -> Any:
    """A new simulator as the recorded run built it (``run_mission``'s defaults)."""
    from kcl.model import UvmsModel
    from sim_backend import SimBackend, load_scenario

    return SimBackend(load_scenario(data["scenario"]), data["seed"], model=UvmsModel.load())


def _bound(sim: Any, calls: list, keep: set | None = None) -> list:
    out = []
    for dev, name, args, _exp in calls:
        if keep is not None and (dev, name) not in keep:
            continue
        target = sim if dev == "backend" else getattr(sim.devices, dev)
        out.append((getattr(target, name), args))
    return out


def count(path: Path, core: bool) -> int:
    """Instructions (callgrind; load-independent) of one replay after a warm-up replay."""
    data = _load(path)
    calls = data["calls"]
    steps = sum(1 for dev, name, *_r in calls if (dev, name) == ("backend", "advance"))
    if os.environ.get(_CHILD):
        keep = None if not core else {(dev, name) for dev, name, *_r in calls if (dev, name) not in READ_ONLY}
        for counted in (False, True):
            sim = _fresh(data)
            sim.devices.vehicle.navigation()  # the first calls of a run (imports, lazy set-ups) not counted
            bound = _bound(sim, calls, keep)
            if counted:
                instrument("on")
            for fn, args in bound:
                fn(*args)
            if counted:
                instrument("off")
        return 0
    total = run_counted(
        __file__, ["count", str(path)] + (["--core"] if core else []), _CHILD, "MARIS_SIM_CALLS_CALLGRIND_OUT"
    )
    if total is None:
        return 1
    what = "the recorded calls but the read-only ones" if core else "every recorded call"
    print(f"instructions of {what}: {total:,} total, {total / steps:,.0f} per base step ({steps} advance calls)")
    print(f"sim_instructions per_step={total / steps:.0f} total={total} steps={steps} core={int(core)}")
    return 0


def replay(path: Path, tol: float) -> int:
    data = _load(path)
    calls = data["calls"]
    sim = _fresh(data)
    worst, worst_at = 0.0, None
    for i, ((fn, args), (dev, name, _a, expected)) in enumerate(zip(_bound(sim, calls), calls)):
        got = fn(*args)
        d = largest_difference(expected, got)
        if d > worst:
            worst, worst_at = d, (i, f"{dev}.{name}")
    print(
        f"{len(calls)} calls replayed; largest difference from the record: {worst:.3g}"
        + (f" (call {worst_at[0]}, {worst_at[1]})" if worst_at else "")
    )
    print(f"sim_calls max_diff={worst:.3g}")
    return 0 if worst <= tol else 1


def main() -> int:
    ap, sub = command_parsers(__doc__.splitlines()[0])
    p = sub.add_parser("replay")
    p.add_argument("path", type=Path)
    p.add_argument("--tol", type=float, default=0.0)
    m = sub.add_parser("compare")
    m.add_argument("a", type=Path)
    m.add_argument("b", type=Path)
    m.add_argument("--tol", type=float, default=0.0)
    c = sub.add_parser("count")
    c.add_argument("path", type=Path)
    c.add_argument("--core", action="store_true", help="leave out the read-only calls (ground truth, health, detector)")
    args = ap.parse_args()
    if args.cmd == "count":
        return count(args.path, args.core)
    if args.cmd == "compare":
        return compare(args.a, args.b, args.tol)
    if args.cmd == "record":
        record(args.out, args.scenario, args.seed)
        return 0
    return replay(args.path, args.tol)


if __name__ == "__main__":
    sys.exit(main())
