"""Compile (first time on a machine) or load the KCL's Numba kernels now.

``python -m kcl.warmup`` builds the default controller once, which compiles the
TPIK solver and the task kernels into numba's on-disk cache (about 30 s on a
2-core machine the first time, about 1 s afterwards). ``make`` runs it after
installing so that no dry run, test or field run pays that cost.
"""

from __future__ import annotations

import time


def main() -> int:
    t0 = time.perf_counter()
    from kcl.actions import load_actions
    from kcl.controller import ControllerConfig, UvmsController
    from kcl.icat import warm_up
    from kcl.model import UvmsModel

    compiled = warm_up()
    model = UvmsModel.load()
    UvmsController(model, load_actions(None, model), ControllerConfig())
    path = "compiled" if compiled else "numpy (Numba unavailable)"
    print(f"KCL kernels ready ({path}) in {time.perf_counter() - t0:.1f} s")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
