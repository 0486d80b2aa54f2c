"""Build and open the devices of a HAL config, as ``maris run`` starts them, and
print one JSON line: how long until the start failed (s, from before the config
is loaded) and why. Run by tests/hal/test_setup_errors.py and
benchmarks/setup_failures.py, inside a network namespace of their own.

    python tests/hal/setup_probe.py HAL_CONFIG
"""

from __future__ import annotations

import json
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[2]))


def main() -> int:
    t0 = time.monotonic()
    from hal.config import load_hal_config
    from hal.factory import build_backend

    error, kind, stage = None, None, "opened"
    backend = None
    try:
        stage = "build"
        backend = build_backend(load_hal_config(sys.argv[1]), realtime=True)
        stage = "open"
        backend.open()
        stage = "opened"
    except Exception as exc:  # noqa: BLE001 - reported, the point of the probe
        error, kind = str(exc), type(exc).__name__
    elapsed = time.monotonic() - t0
    if backend is not None:
        backend.close()
    print(json.dumps({"elapsed_s": elapsed, "stage": stage, "error": error, "type": kind}), flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
