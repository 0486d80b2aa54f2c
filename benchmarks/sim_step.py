"""Cost of one simulator step (all devices), in microseconds of wall time.

Runs the ``pool_clear`` scenario with the vehicle and the arm moving, and times
``advance(0.01)`` (one 10 ms step: arm, vehicle - by default the full model:
DCL, 8 thrusters, 6-DOF rigid body and the arm's reaction through Pinocchio;
``--model first_order`` for the fast kinematic lag -, gripper, AHRS 100 Hz, DVL
5 Hz, vision 10 Hz) plus the reads a controller does every cycle (navigation, joint
state). Prints the median and percentiles over blocks of steps (CPU time of this
process, so other jobs on a shared machine inflate it less; wall time is shown
too), then the implied real-time factor at 100 Hz. Last line:
``sim_step median_us=...`` (CPU time, with the reads).

Usage: ``python benchmarks/sim_step.py [--steps 6000] [--scenario pool_clear] [--model full|first_order]``
"""

from __future__ import annotations

import argparse
import statistics
import time

import numpy as np

from sim_backend import SimBackend, load_scenario


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--steps", type=int, default=6000)
    ap.add_argument("--block", type=int, default=100)
    ap.add_argument("--scenario", default="pool_clear")
    ap.add_argument(
        "--model",
        choices=("full", "first_order"),
        default=None,
        help="vehicle model (default: the scenario's, full for the shipped ones)",
    )
    args = ap.parse_args()

    sim = SimBackend(load_scenario(args.scenario, {"vehicle.model": args.model} if args.model else None), seed=1)
    sim.open()
    d = sim.devices
    d.vehicle.arm()
    d.arm.enable()
    n = len(d.arm.joint_names)
    v = np.array([0.15, 0.02, 0.01, 0.0, 0.0, 0.03])
    qdot = np.full(n, 0.02)
    for _ in range(200):  # warm up
        sim.advance(0.01)

    def block(reads: bool) -> tuple[float, float]:
        t0, w0 = time.process_time(), time.perf_counter()
        for _ in range(args.block):
            d.vehicle.command_body_velocity(v)
            d.arm.command_joint_velocity(qdot)
            sim.advance(0.01)
            if reads:
                d.vehicle.navigation()
                d.arm.joint_state()
                d.detector.latest()
        return (time.process_time() - t0) / args.block * 1e6, (time.perf_counter() - w0) / args.block * 1e6

    blocks = max(1, args.steps // args.block)
    bare_runs = [block(False) for _ in range(blocks)]
    full_runs = [block(True) for _ in range(blocks)]
    bare = sorted(c for c, _ in bare_runs)
    full = sorted(c for c, _ in full_runs)
    wall = sorted(w for _, w in full_runs)
    pct = lambda xs, p: xs[min(len(xs) - 1, int(p * len(xs)))]  # noqa: E731
    print(
        f"scenario={args.scenario} vehicle.model={sim.params['vehicle.model']} steps={blocks * args.block} (x2) "
        f"block={args.block}"
    )
    print(f"wall: advance + device reads  median_us={statistics.median(wall):.1f} p90={pct(wall, 0.9):.1f}")
    print(
        f"cpu: advance(0.01) only      median_us={statistics.median(bare):.1f} p10={pct(bare, 0.1):.1f} p90={pct(bare, 0.9):.1f}"
    )
    print(
        f"cpu: advance + device reads  median_us={statistics.median(full):.1f} p10={pct(full, 0.1):.1f} p90={pct(full, 0.9):.1f}"
    )
    print(f"real-time factor at 100 Hz (with reads): {1e4 / statistics.median(full):.0f}x")
    print(f"sim_step median_us={statistics.median(full):.1f}")


if __name__ == "__main__":
    main()
