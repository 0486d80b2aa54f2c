"""Compile (first time on a machine) or load the KCL's Numba kernels now.

``python -m kcl.warmup`` builds the default controller once, which compiles the
controller's cycle, the TPIK solver and the task kernels into Numba's on-disk
cache (tens of seconds on a 2-core machine the first time, about a second
afterwards). ``make`` runs it after installing so that no dry run, test or field
run pays that cost.
"""

from __future__ import annotations

import time

from kcl.actions import load_actions
from kcl.controller import ControllerConfig, UvmsController
from kcl.icat import tpik
from kcl.model import UvmsModel


def main() -> int:
    t0 = time.perf_counter()
    model = UvmsModel.load()
    UvmsController(model, load_actions(None, model), ControllerConfig())
    tpik([(1.0 * (model.neutral()[None, :] == 0.0), [1.0], [0.0])])  # the public solver's own entry
    print(f"KCL kernels ready in {time.perf_counter() - t0:.1f} s")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
