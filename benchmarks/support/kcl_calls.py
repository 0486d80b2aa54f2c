"""Record every call the supervisor makes to the KCL controller during a dry
run, then replay them into a fresh controller: a KCL-only benchmark of the
real workload (per-call wall time of ``vehicle_step`` / ``arm_step``) and an
exactness check (every reference and telemetry snapshot compared with the
recorded one; bit for bit unless a tolerance is given).

    .venv/bin/python benchmarks/support/kcl_calls.py record OUT.pkl [--scenario pool_fixed] [--seed 1]
    .venv/bin/python benchmarks/support/kcl_calls.py replay OUT.pkl [--repeat 3] [--tol 0]
    .venv/bin/python benchmarks/support/kcl_calls.py compare A.pkl B.pkl [--tol 0]
    .venv/bin/python benchmarks/support/kcl_calls.py count OUT.pkl     # callgrind, minutes
        (MARIS_KCL_CALLS_CALLGRIND_OUT=FILE keeps callgrind's profile for callgrind_annotate)

``record`` runs ``missions/maris_pipe_recovery.yaml`` on the simulator without
a log and stores, in call order, the controller's construction (URDF, frames,
actions file, config) and each call of ``set_action``, ``stop``,
``set_targets``, ``clear_targets``, ``vehicle_step``, ``arm_step``, ``step``,
``telemetry`` and ``status`` with its arguments and result. ``replay`` runs them again
(``--repeat`` times, fresh controller each time; the kernels are loaded
before timing; the first repeat, which also compares, is not timed) and prints
the mean wall time per call of each step kind in its fastest repeat, the
largest difference from the recorded results, and a last machine-readable line
``kcl_calls vehicle_us=... arm_us=... telemetry_us=... max_diff=...``.
``compare`` checks two records of the closed loop (before and after a change
that rounds differently): the same outcome and calls in the same order, and
the largest difference of any argument (the measurements the controller got)
or result (its references) per kind of call; last line
``kcl_compare max_diff=... same_calls=0|1``.
"""

from __future__ import annotations

import copy
import os
import pickle
import sys
import time
from pathlib import Path
from typing import Any

sys.path.insert(0, str(Path(__file__).resolve().parent))
from call_records import command_parsers, instrument, largest_difference, run_counted  # noqa: E402

ROOT = Path(__file__).resolve().parents[2]
_CHILD = "MARIS_KCL_CALLS_CHILD"
_WRAPPED = (
    "set_action",
    "stop",
    "set_targets",
    "clear_targets",
    "vehicle_step",
    "arm_step",
    "step",
    "telemetry",
    "status",
)


def record(out: Path, scenario: str, seed: int) -> None:
    sys.path.insert(0, str(ROOT))
    from mission.runtime.api import run_mission
    from mission.runtime.options import RunHooks, RunOptions, RunTarget

    calls: list[tuple[str, tuple, dict, Any]] = []
    header: dict[str, Any] = {}

    def hook(supervisor: Any) -> None:
        ctl = supervisor.controller
        header.update(
            urdf=ctl.model.urdf_path,
            frames=dict(ctl.model.frames),
            actions=supervisor.ctx.mission.actions_file,
            config=copy.deepcopy(ctl.config),
        )
        for name in _WRAPPED:
            inner = getattr(ctl, name)

            def wrapper(*args: Any, _inner: Any = inner, _name: str = name, **kwargs: Any) -> Any:
                saved = copy.deepcopy((args, kwargs))
                result = _inner(*args, **kwargs)
                calls.append((_name, saved[0], saved[1], copy.deepcopy(result)))
                return result

            setattr(ctl, name, wrapper)

    result = run_mission(
        RunTarget(ROOT / "missions" / "maris_pipe_recovery.yaml", scenario=scenario, seed=seed),
        RunOptions(log_path=None),
        RunHooks(on_supervisor=hook),
    )
    with open(out, "wb") as fh:
        pickle.dump({"header": header, "calls": calls, "outcome": result.outcome}, fh)
    kinds: dict[str, int] = {}
    for name, *_rest in calls:
        kinds[name] = kinds.get(name, 0) + 1
    print(f"recorded {len(calls)} calls ({kinds}); outcome {result.outcome}")


def _load(path: Path) -> tuple[dict, list, Any, Any]:
    """The record at ``path``: ``(header, calls, model, actions)``, the model and
    actions loaded as the recorded run had them."""
    sys.path.insert(0, str(ROOT))
    from kcl.actions import load_actions
    from kcl.model import UvmsModel

    with open(path, "rb") as fh:
        data = pickle.load(fh)
    h, calls = data["header"], data["calls"]
    model = UvmsModel.load(h["urdf"], h["frames"])
    return h, calls, model, load_actions(h["actions"] or None, model)


def count(path: Path) -> int:
    """Instructions (valgrind's callgrind; load-independent) of one replay of
    every recorded call, after a warm-up replay; printed per arm step (= per
    10 ms base step of the recorded run)."""
    if os.environ.get(_CHILD):
        h, calls, model, actions = _load(path)
        from kcl.controller import UvmsController

        for counted in (False, True):
            ctl = UvmsController(model, actions, copy.deepcopy(h["config"]))
            bound = [(getattr(ctl, name), args, kwargs) for name, args, kwargs, _exp in calls]
            if counted:
                instrument("on")
            for fn, args, kwargs in bound:
                fn(*args, **kwargs)
            if counted:
                instrument("off")
        return 0
    total = run_counted(__file__, ["count", str(path)], _CHILD, "MARIS_KCL_CALLS_CALLGRIND_OUT")
    if total is None:
        return 1
    with open(path, "rb") as fh:
        calls = pickle.load(fh)["calls"]
    steps = sum(1 for name, *_rest in calls if name in ("arm_step", "step"))
    print(
        f"instructions of every recorded controller call: {total:,} total, {total / steps:,.0f} per arm step ({steps})"
    )
    print(f"kcl_instructions per_step={total / steps:.0f} total={total} steps={steps}")
    return 0


def replay(path: Path, repeat: int, tol: float) -> int:
    h, calls, model, actions = _load(path)
    from kcl.controller import UvmsController

    totals: dict[str, float] = {}
    counts: dict[str, int] = {}
    worst = 0.0
    worst_at = None
    clock = time.perf_counter
    for rep in range(repeat):
        ctl = UvmsController(model, actions, copy.deepcopy(h["config"]))
        rep_totals: dict[str, float] = {}
        for i, (name, args, kwargs, expected) in enumerate(calls):
            fn = getattr(ctl, name)
            t0 = clock()
            got = fn(*args, **kwargs)
            rep_totals[name] = rep_totals.get(name, 0.0) + clock() - t0
            if rep == 0:
                counts[name] = counts.get(name, 0) + 1
                d = largest_difference(expected, got)
                if d > worst:
                    worst, worst_at = d, (i, name)
        if rep > 0 or repeat == 1:  # the least disturbed repeat of each kind (shared machine)
            for name, total in rep_totals.items():
                totals[name] = min(totals.get(name, total), total)
    for name in sorted(totals):
        print(f"{name:14s} {counts[name]:7d} calls  {1e6 * totals[name] / counts[name]:8.1f} us/call")
    print(
        f"largest difference from the record: {worst:.3g}"
        + (f" (call {worst_at[0]}, {worst_at[1]})" if worst_at else "")
    )
    us = {k: 1e6 * totals.get(k, 0.0) / max(1, counts.get(k, 0)) for k in ("vehicle_step", "arm_step", "telemetry")}
    print(
        f"kcl_calls vehicle_us={us['vehicle_step']:.1f} arm_us={us['arm_step']:.1f} "
        f"telemetry_us={us['telemetry']:.1f} max_diff={worst:.3g}"
    )
    return 0 if worst <= tol else 1


def compare(a_path: Path, b_path: Path, tol: float) -> int:
    """Two records of the closed loop: same calls, and their largest differences (see the module docstring)."""
    recs = []
    for path in (a_path, b_path):
        with open(path, "rb") as fh:
            recs.append(pickle.load(fh))
    a, b = recs
    print(f"outcome {a['outcome']} / {b['outcome']}")
    names_a, names_b = [c[0] for c in a["calls"]], [c[0] for c in b["calls"]]
    if names_a != names_b:
        first = next((i for i, (x, y) in enumerate(zip(names_a, names_b)) if x != y), min(len(names_a), len(names_b)))
        print(f"call sequences differ from call {first} ({len(names_a)} / {len(names_b)} calls)")
        print("kcl_compare max_diff=inf same_calls=0")
        return 1
    worst: dict[str, tuple[float, int]] = {}
    for i, (ca, cb) in enumerate(zip(a["calls"], b["calls"])):
        d = max(largest_difference(ca[1], cb[1]), largest_difference(ca[2], cb[2]), largest_difference(ca[3], cb[3]))
        if d > worst.get(ca[0], (-1.0, 0))[0]:
            worst[ca[0]] = (d, i)
    for name, (d, i) in sorted(worst.items()):
        print(f"  {name:<14} largest difference {d:.3g} (call {i})")
    top = max([d for d, _i in worst.values()], default=0.0)
    print(f"{len(names_a)} calls, same sequence")
    print(f"kcl_compare max_diff={top:.3g} same_calls=1")
    return 0 if a["outcome"] == b["outcome"] and top <= tol else 1


def main() -> int:
    ap, sub = command_parsers(__doc__.splitlines()[0])
    p = sub.add_parser("replay")
    p.add_argument("path", type=Path)
    p.add_argument("--repeat", type=int, default=3)
    p.add_argument("--tol", type=float, default=0.0)
    c = sub.add_parser("count")
    c.add_argument("path", type=Path)
    k = sub.add_parser("compare")
    k.add_argument("a", type=Path)
    k.add_argument("b", type=Path)
    k.add_argument("--tol", type=float, default=0.0)
    args = ap.parse_args()
    if args.cmd == "compare":
        return compare(args.a, args.b, args.tol)
    if args.cmd == "count":
        return count(args.path)
    if args.cmd == "record":
        record(args.out, args.scenario, args.seed)
        return 0
    return replay(args.path, args.repeat, args.tol)


if __name__ == "__main__":
    sys.exit(main())
