"""Speed of one full KCL cycle of the ``grasp`` action, typical and worst case, against pin-pink.

Full cycle = the runtime's vehicle tick, ``UvmsController.step(meas, t)``:
``vehicle_step`` then ``arm_step`` at the same state, exactly as
``mission.runtime.supervisor`` calls them (kinematics and Jacobians, the tasks,
TPIK 1 (13 DOF, vehicle references) and TPIK 2 (7 joints against the measured
vehicle velocity)), steady grasp action (transition over): one compiled call
per TPIK (kcl.cycle). Also timed: the arm tick (``arm_step`` alone, at another
state, as the runtime runs it between vehicle ticks), and the two TPIK solves
on their own (the stacks of each vehicle tick solved again by
``kcl.icat_kernel.solve``, untimed in the cycle figure: the cycle's own solves
run inside its compiled calls).

Two workloads (benchmarks/support/grasp_states.py), each printed with the
levels and rows (a > 0) its two TPIKs really solved:

* typical: 600 states of a closed-loop grasp. Most of them activate only the
  equality tasks and the horizontal attitude (TPIK 1 4 levels / 15 rows,
  TPIK 2 3 levels / 13 rows): manipulability, occlusion, camera centering,
  joint limits, altitude and the geofence (none set) are idle there.
* worst: 200 states where every row of every grasp task is active in both
  TPIKs (all joints in their limit bands, low manipulability, the elbow near
  the camera's line of sight, target off the optical axis, tilted vehicle, low
  altitude, the vehicle near the geofence's lower faces): TPIK 1 10 levels / 29
  rows, TPIK 2 6 levels / 22 rows, each plus
  the final minimum-velocity level (13 / 7 rows).

Baseline: pin-pink (benchmarks/support/pink_stack.py) on the same URDF: ONE
weighted QP per cycle (daqp) with the tool-frame and posture tasks as cost
rows, Tikhonov damping, joint and velocity limits and one barrier (CBF) row per
other inequality task of the grasp action; see that module for what is and is
not equivalent (no strict hierarchy, no smooth activations, one QP where the
KCL solves two). Also shown: pink with only the tasks active in the typical
states, and the time of pink's QP solve alone.

Ours and pink run in interleaved blocks so that both see the same machine
load; the load average is printed. The last line is machine-readable:
``kcl_cycle median_us=... p99_us=... worst_median_us=... worst_p99_us=...
pink_us=... pink_worst_us=... ratio=... worst_ratio=...`` (medians of the
full cycle; ratio = ours / pink on the same workload, lower is better).

Usage: ``python benchmarks/kcl_cycle.py [--cycles N] [--no-pink]``.
"""

from __future__ import annotations

import argparse
import collections
import gc
import os
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

from support.grasp_states import (
    StateSet,
    full_shape,
    make_controller,
    shapes_of,  # noqa: E402
    typical_states,
    worst_states,
)

from kcl.actions import load_actions  # noqa: E402
from kcl.controller import MeasuredState  # noqa: E402
from kcl.icat_kernel import solve  # noqa: E402
from kcl.model import UvmsModel  # noqa: E402

BLOCK = 250  # cycles per interleaved block


class OursTimer:
    """Times the runtime's two kinds of controller tick on the workload's states:
    a vehicle tick (``step``: ``vehicle_step`` then ``arm_step`` at one state, as
    ``mission.runtime.supervisor`` runs them) and an arm tick (``arm_step`` alone,
    at another state); then, untimed, re-solves the two stacks the vehicle tick
    built to time the TPIK solves on their own."""

    def __init__(self, model: UvmsModel, actions, workload: StateSet):
        self.workload = workload
        self.ctrl = make_controller(model, actions, workload)
        self.k = 0
        self.full: list[float] = []
        self.solves: list[float] = []
        self.arm: list[float] = []

    def resolve(self) -> float:
        """Time (s) of solving again the stacks of the last vehicle tick, each by
        one call of the compiled solver (:func:`kcl.icat_kernel.solve`)."""
        clock = time.perf_counter
        total = 0.0
        for problem in (self.ctrl.tpik1, self.ctrl.tpik2):
            count = problem.levels
            if count:
                st = problem.stack
                n = st.J.shape[1]
                raw, applied, factors = np.empty((count + 1, n)), np.empty((count + 1, n)), np.empty(count + 1)
                t0 = clock()
                solve(
                    st.J,
                    st.a,
                    st.xdot,
                    st.offsets[: count + 1],
                    st.lams[:count],
                    st.ths[:count],
                    True,
                    problem.plan.lam,
                    problem.plan.threshold,
                    problem.plan.eta,
                    problem.plan.limits,
                    True,
                    raw,
                    applied,
                    factors,
                )
                total += clock() - t0
        return total

    def block(self, cycles: int, record: bool = True) -> None:
        states = self.workload.states
        n = len(states)
        ctrl = self.ctrl
        clock = time.perf_counter
        for _ in range(cycles):
            k = self.k = self.k + 1
            t = 100.0 + 0.01 * k
            s = states[k % n]
            meas = MeasuredState(s.q, s.eta, s.v, t, s.altitude)
            s2 = states[(k + n // 2) % n]  # arm tick at another state (nothing shared or cached)
            meas2 = MeasuredState(s2.q, s2.eta, s2.v, t + 0.005, s2.altitude)
            t0 = clock()
            ctrl.step(meas, t)
            t1 = clock()
            solves = self.resolve() if record else 0.0
            t2 = clock()
            ctrl.arm_step(meas2, t + 0.005)
            t3 = clock()
            if record:
                self.full.append(t1 - t0)
                self.solves.append(solves)
                self.arm.append(t3 - t2)


class PinkTimer:
    """Times pink's cycle (update + solve_ik) on the workload's states."""

    def __init__(self, model: UvmsModel, actions, workload: StateSet, full: bool):
        from support.pink_stack import PinkGrasp, pink_inputs

        camera = workload.camera_target if workload.camera_target is not None else workload.tool_goal[:3, 3]
        self.pink = PinkGrasp(model, actions, workload.tool_goal, camera, full=full)
        self.inputs = pink_inputs(workload.states)
        self.k = 0
        self.times: list[float] = []
        self.solve: list[float] = []

    def block(self, cycles: int, record: bool = True) -> None:
        clock = time.perf_counter
        n = len(self.inputs)
        for _ in range(cycles):
            self.k += 1
            q, alt = self.inputs[self.k % n]
            t0 = clock()
            v = self.pink.cycle(q, alt)
            t1 = clock()
            if record:
                self.times.append(t1 - t0)
        if not np.all(np.isfinite(v)):
            raise RuntimeError("pink returned a non-finite velocity")

    def solve_only(self, cycles: int) -> None:
        """Separate pass: time of the daqp solve alone (QP already built)."""
        n = len(self.inputs)
        for k in range(cycles):
            q, alt = self.inputs[k % n]
            self.solve.append(self.pink.build_and_solve(q, alt)[1])


def us(values: list[float], q: float | None = None) -> float:
    arr = np.asarray(values) * 1e6
    return float(np.median(arr) if q is None else np.percentile(arr, q))


def shape_summary(model, actions, workload: StateSet) -> str:
    counts = collections.Counter(s.text() for s in shapes_of(model, actions, workload))
    return "; ".join(f"{c} x {text}" for text, c in counts.most_common())


def run_workload(model, actions, workload: StateSet, cycles: int, pinks: dict[str, bool]) -> tuple[OursTimer, dict]:
    ours = OursTimer(model, actions, workload)
    others = {label: PinkTimer(model, actions, workload, full) for label, full in pinks.items()}
    ours.block(BLOCK, record=False)  # warm-up
    for p in others.values():
        p.block(BLOCK // 5, record=False)
    gc.disable()
    try:
        done = 0
        while done < cycles:
            step = min(BLOCK, cycles - done)
            ours.block(step)
            for p in others.values():
                p.block(step)
            done += step
        for p in others.values():
            p.solve_only(min(cycles, 1000))
    finally:
        gc.enable()
    return ours, others


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--cycles", type=int, default=3000, help="timed cycles per workload")
    parser.add_argument("--no-pink", action="store_true", help="skip the pink baseline")
    args = parser.parse_args()
    model = UvmsModel.load()
    actions = load_actions(model=model)
    typical = typical_states(model, actions, 600)
    worst = worst_states(model, actions, 200)
    full = full_shape(model, actions)
    load1 = os.getloadavg()[0]
    print(
        f"grasp action: {len(actions.tasks_of('grasp'))} tasks in {full.levels1} priority levels, n = {model.n} "
        f"(l = {model.n_joints} joints + 6 vehicle DOFs); {args.cycles} timed cycles per workload; "
        f"load average {load1:.1f} on {os.cpu_count()} CPUs"
    )
    print(
        f"TPIK shapes below exclude the final minimum-velocity level ({model.n} rows in TPIK 1, "
        f"{model.n_joints} in TPIK 2), which runs unless the stack already took every DOF"
    )
    if not args.no_pink:
        print(
            "pink solves ONE weighted QP per cycle (soft priorities by weight, the grasp action's inequality "
            "tasks as hard barrier rows, no TPIK 2 re-solve of the arm); see benchmarks/support/pink_stack.py"
        )
    results = {}
    for workload, pinks in (
        (typical, {"pink, same grasp stack": True, "pink, only the typical active tasks": False}),
        (worst, {"pink, same grasp stack": True}),
    ):
        ours, others = run_workload(model, actions, workload, args.cycles, {} if args.no_pink else pinks)
        results[workload.name] = (ours, others)
        print(f"\n{workload.name} ({len(workload.states)} states): {shape_summary(model, actions, workload)}")
        print(
            f"  ours, full cycle = vehicle tick (vehicle_step + arm_step, one state): median {us(ours.full):.0f} us, "
            f"p99 {us(ours.full, 99):.0f} us, min {min(ours.full) * 1e6:.0f} us"
        )
        print(f"    the two TPIK solves alone (re-solved from its stacks): median {us(ours.solves):.0f} us")
        print(
            f"  ours, arm tick (arm_step alone, another state: kinematics + TPIK 2): median {us(ours.arm):.0f} us, "
            f"p99 {us(ours.arm, 99):.0f} us"
        )
        for label, p in others.items():
            cost, cons, bars = p.pink.shape()
            print(
                f"  {label} (1 QP, 13 DOF: {cost} cost rows + damping, {cons} constraint rows of which {bars} barrier): "
                f"median {us(p.times):.0f} us, p99 {us(p.times, 99):.0f} us, min {min(p.times) * 1e6:.0f} us; "
                f"its QP solve alone (daqp) median {us(p.solve):.0f} us"
            )
    t_ours, t_pink = results["typical"]
    w_ours, w_pink = results["worst"]
    med, wmed = us(t_ours.full), us(w_ours.full)
    pink_t = us(t_pink["pink, same grasp stack"].times) if t_pink else float("nan")
    pink_w = us(w_pink["pink, same grasp stack"].times) if w_pink else float("nan")
    met = wmed <= 200.0 and wmed < pink_w
    print(
        f"\ntarget: worst state (every task active) <= 200 us median and faster than pink on the same stack: "
        f"{'met' if met else 'MISSED'} ({wmed:.0f} us; pink {pink_w:.0f} us)"
    )
    print(
        f"kcl_cycle median_us={med:.0f} p99_us={us(t_ours.full, 99):.0f} worst_median_us={wmed:.0f} "
        f"worst_p99_us={us(w_ours.full, 99):.0f} pink_us={pink_t:.0f} pink_worst_us={pink_w:.0f} "
        f"ratio={med / pink_t:.2f} worst_ratio={wmed / pink_w:.2f}"
    )


if __name__ == "__main__":
    main()
