"""A host process driving a Reach arm, for the exit-path tests: loads a HAL config,
connects the arm, enables it and commands a constant joint velocity at 100 Hz,
printing ``MOVING`` once it does, until killed (or ``--seconds`` pass).

    python tests/hal/reach_host.py HAL_CONFIG --velocity 0.3 [--seconds 30]
"""

from __future__ import annotations

import argparse
import signal
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[2]))

from hal.config import load_hal_config  # noqa: E402
from hal.drivers.reach_arm import ReachArm  # noqa: E402
from hal.drivers.realtime import MonotonicClock  # noqa: E402


def main() -> int:
    ap = argparse.ArgumentParser()
    ap.add_argument("config")
    ap.add_argument("--velocity", type=float, default=0.3)
    ap.add_argument("--seconds", type=float, default=30.0)
    args = ap.parse_args()
    # Ctrl-C interrupts it as it does an interactive program, whatever the launching
    # process left behind (an ignored SIGINT or a blocked one is inherited across exec)
    signal.signal(signal.SIGINT, signal.default_int_handler)
    signal.pthread_sigmask(signal.SIG_UNBLOCK, {signal.SIGINT, signal.SIGTERM})
    clock = MonotonicClock()
    arm = ReachArm(load_hal_config(args.config).devices["arm"].params, clock.now)
    arm.connect()
    deadline = time.monotonic() + 3.0
    while arm.health().state.value != "ok" and time.monotonic() < deadline:
        time.sleep(0.05)
    arm.enable()
    qdot = np.full(len(arm.joint_names), args.velocity)
    end = time.monotonic() + args.seconds
    said = False
    while time.monotonic() < end:
        arm.command_joint_velocity(qdot)
        if not said:
            print("MOVING", flush=True)
            said = True
        time.sleep(0.01)
    arm.disconnect()
    return 0


if __name__ == "__main__":
    sys.exit(main())
