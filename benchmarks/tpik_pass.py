"""Time one TPIK pass: kcl.icat.tpik (the compiled recursion) against the plain
transcription of the spec.

The pass (issue 2, part 5): 13 DOF, levels of dimensions 1, 1, 1, 3, 6, 1, 6, 3
with random Jacobians and activations in (0, 1), then the final 13-DOF
minimum-velocity level (``min_velocity=True``): 9 levels. All solvers run on
the same stacks in the same process; the results are checked equal to 1e-9
first. The baseline is the literal transcription of icat.md
(``tests/kcl/oracle.py``: one SVD per pseudo-inverse, every matrix formed), the
tests' oracle. ``kcl.icat.tpik`` validates its arguments in Python before the
compiled call: the figure includes that.

Prints a few extra figures (small stacks, saturation on), then, as its last line:
``tpik_pass median_us=... p99_us=... straightforward_us=... speedup=...``
(speedup = the baseline's median / the kernel's median).

Usage: python benchmarks/tpik_pass.py [--calls N] [--seed S]
"""

from __future__ import annotations

import argparse
import gc
import os
import sys
import time
from pathlib import Path

import numpy as np

from kcl.icat import tpik

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests" / "kcl"))
import oracle as icat_reference  # noqa: E402 - the tests' transcription of the spec

N_DOF = 13
DIMS = (1, 1, 1, 3, 6, 1, 6, 3)


def make_stacks(rng: np.random.Generator, count: int, dims=DIMS, n=N_DOF) -> list:
    """``count`` random stacks: (J, a, xdot) per level, activations in (0, 1)."""
    return [
        [(rng.standard_normal((m, n)), rng.uniform(1e-3, 1.0 - 1e-3, m), rng.standard_normal(m)) for m in dims]
        for _ in range(count)
    ]


def time_calls(fn, stacks: list, calls: int, **kwargs) -> np.ndarray:
    """Per-call wall times in microseconds, cycling through ``stacks``."""
    for s in stacks[:10]:
        fn(s, **kwargs)  # warm-up
    out = np.empty(calls)
    clock = time.perf_counter
    gc.disable()
    try:
        for i in range(calls):
            s = stacks[i % len(stacks)]
            t0 = clock()
            fn(s, **kwargs)
            out[i] = clock() - t0
    finally:
        gc.enable()
    return out * 1e6


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--calls", type=int, default=3000, help="timed calls of the fast solver")
    parser.add_argument("--seed", type=int, default=1)
    args = parser.parse_args()
    rng = np.random.default_rng(args.seed)
    stacks = make_stacks(rng, 64)
    t0 = time.perf_counter()
    tpik(stacks[0], min_velocity=True)
    print(f"load/compile {time.perf_counter() - t0:.2f} s (the first run on a machine compiles)")

    worst = max(
        float(np.max(np.abs(tpik(s, min_velocity=True) - icat_reference.tpik(s, min_velocity=True)))) for s in stacks
    )
    if worst > 1e-9:
        raise SystemExit(f"fast and straightforward results differ by {worst:.3g} > 1e-9")
    print(f"max |fast - straightforward| over {len(stacks)} stacks: {worst:.2e}")

    ref_calls = max(200, args.calls // 10)
    fast = time_calls(tpik, stacks, args.calls, min_velocity=True)
    slow = time_calls(icat_reference.tpik, stacks, ref_calls, min_velocity=True)
    limits = np.full(N_DOF, 0.3)
    sat = time_calls(tpik, stacks, args.calls // 3, min_velocity=True, limits=limits)
    small = make_stacks(rng, 16, dims=(6,), n=N_DOF)
    small_t = time_calls(tpik, small, args.calls // 3)
    small_mv = time_calls(tpik, small, args.calls // 3, min_velocity=True)

    print(f"9-level pass, limits on: median {np.median(sat):.1f} us")
    print(f"one 6-row level: median {np.median(small_t):.1f} us; with min_velocity: {np.median(small_mv):.1f} us")
    med, p99, ref_med = np.median(fast), np.percentile(fast, 99), np.median(slow)
    print(f"compiled kernel:                      median {med:.1f} us, p99 {p99:.1f} us")
    print(f"literal transcription (tests/kcl/oracle.py): median {ref_med:.1f} us ({ref_med / med:.1f}x the kernel)")
    print(f"load average {os.getloadavg()[0]:.1f} on {os.cpu_count()} CPUs")
    print(
        f"tpik_pass median_us={med:.1f} p99_us={p99:.1f} straightforward_us={ref_med:.1f} speedup={ref_med / med:.2f}"
    )


if __name__ == "__main__":
    main()
