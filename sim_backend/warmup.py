"""Compile (first time) or load the simulator's Numba kernels: ``python -m sim_backend.warmup``.

The full vehicle model (:mod:`sim_backend.vehicle_kernel`, :mod:`sim_backend.thrusters`)
is compiled once per machine and cached next to the sources; ``make`` runs this
at install so the first dry run or test does not pay for it.
"""

from __future__ import annotations

import time


def main() -> None:
    t0 = time.perf_counter()
    from sim_backend import SimBackend, load_scenario

    sim = SimBackend(load_scenario("pool_fixed"), seed=0)
    sim.open()
    sim.advance(0.02)
    print(f"simulator kernels ready ({time.perf_counter() - t0:.1f} s)")


if __name__ == "__main__":
    main()
