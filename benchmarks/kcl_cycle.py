"""Speed of one full KCL cycle on the default UVMS, against pin-pink.

Cycle = kinematics and Jacobians, TPIK 1 (vehicle references) and TPIK 2
(joint references) of the ``grasp`` action: ``UvmsController.step(meas, t)``.
The states are taken from a closed-loop grasp run (so the activations are the
real mixture of active, transitioning and idle tasks) and replayed in a loop.

Baseline: the closest stack pin-pink can express on the same model (Pinocchio
free-flyer + arm): tool frame pose, joint limits (pink's configuration and
velocity limits), preferred posture, vehicle velocity minimization, as ONE
weighted QP solved by daqp, per cycle ``Configuration.update`` + ``solve_ik``.
Pink solves fewer tasks (no manipulability, occlusion, camera, attitude,
altitude) and a weighted compromise, not a strict hierarchy.

Usage: ``python benchmarks/kcl_cycle.py [--cycles N]``. The last line is
``kcl_cycle median_us=... p99_us=... pink_us=... ratio=...`` (ratio = ours / pink).
"""

from __future__ import annotations

import argparse
import gc
import time

import numpy as np
import pinocchio as pin

from kcl.actions import load_actions
from kcl.controller import ControllerConfig, MeasuredState, UvmsController
from kcl.model import DEFAULT_URDF, UvmsModel
from kcl.rotations import integrate_pose, rpy_to_matrix

FLOOR = 11.3  # m


def grasp_states(model: UvmsModel, actions, n_states: int) -> tuple[list[MeasuredState], np.ndarray]:
    """States of a closed-loop grasp (perfect tracking, 100 Hz) and its goal."""
    eta = np.array([0.0, 0.0, 10.0, 0.0, 0.0, 0.4])
    q = np.array(actions.postures["grasp_ready"]) + 0.25
    goal = model.frame_pose_world(np.array(actions.postures["grasp_ready"]) - 0.1, eta + np.r_[0.2, -0.1, 0.1, 0, 0, 0.2], "tool")
    ctrl = UvmsController(model, actions, ControllerConfig())
    ctrl.set_targets(tool_goal=goal)
    ctrl.set_action("grasp", 0.0)
    states = []
    v = np.zeros(6)
    for k in range(n_states):
        t = 0.01 * k
        meas = MeasuredState(q.copy(), eta.copy(), v.copy(), t, FLOOR - eta[2])
        states.append(meas)
        if k % 10 == 0:
            v = ctrl.vehicle_step(meas, t)
        q = q + 0.01 * ctrl.arm_step(meas, t)
        eta = integrate_pose(eta, v, 0.01)
    return states, goal


def time_ours(model, actions, states, goal, cycles: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Per cycle: full step, the TPIK solves inside it, a lone arm_step (s)."""
    ctrl = UvmsController(model, actions, ControllerConfig())
    ctrl.set_targets(tool_goal=goal)
    ctrl.set_action("grasp", -10.0)  # transition over: the steady grasp stack
    solve_time = [0.0]
    run_tpik = ctrl._run_tpik

    def timed_tpik(*args):
        t0 = time.perf_counter()
        out = run_tpik(*args)
        solve_time[0] += time.perf_counter() - t0
        return out

    ctrl._run_tpik = timed_tpik
    full = np.empty(cycles)
    solves = np.empty(cycles)
    arm = np.empty(cycles)
    n = len(states)
    for k in range(cycles):
        s = states[k % n]
        t = 100.0 + 0.01 * k
        solve_time[0] = 0.0
        t0 = time.perf_counter()
        ctrl.step(MeasuredState(s.q, s.eta, s.v, t, s.altitude), t)
        t1 = time.perf_counter()
        full[k] = t1 - t0
        solves[k] = solve_time[0]
        s2 = states[(k + n // 2) % n]  # arm step alone at another state (nothing shared or cached)
        t0 = time.perf_counter()
        ctrl.arm_step(MeasuredState(s2.q, s2.eta, s2.v, t + 0.005, s2.altitude), t + 0.005)
        arm[k] = time.perf_counter() - t0
    return full * 1e6, solves * 1e6, arm * 1e6


def time_pink(actions, states, goal, cycles: int) -> np.ndarray:
    import pink
    from pink.tasks import FrameTask, PostureTask, Task

    class VehicleVelocityTask(Task):
        """Minimise the free-flyer (vehicle) velocity: e = 0, J = [I_6 0]."""

        def compute_error(self, configuration):
            return np.zeros(6)

        def compute_jacobian(self, configuration):
            J = np.zeros((6, configuration.model.nv))
            J[:, :6] = np.eye(6)
            return J

        def __repr__(self) -> str:
            return "VehicleVelocityTask()"

    ff = pin.buildModelFromUrdf(str(DEFAULT_URDF), pin.JointModelFreeFlyer())
    ff.velocityLimit[:6] = ControllerConfig().vehicle_velocity_limit
    ff.lowerPositionLimit[:7] = -1e3
    ff.upperPositionLimit[:7] = 1e3

    def to_pin(s: MeasuredState) -> np.ndarray:
        quat = pin.Quaternion(rpy_to_matrix(*s.eta[3:]))
        return np.concatenate([s.eta[:3], quat.coeffs(), s.q])

    qs = [to_pin(s) for s in states]
    config = pink.Configuration(ff, ff.createData(), qs[0])
    tool = FrameTask("tool", position_cost=1.0, orientation_cost=1.0)
    tool.set_target(pin.SE3(goal[:3, :3], goal[:3, 3]))
    posture = PostureTask(cost=1e-2)
    posture_q = qs[0].copy()
    posture_q[7:] = actions.postures["grasp_ready"]
    posture.set_target(posture_q)
    vehicle = VehicleVelocityTask(cost=1e-2, gain=1.0)
    tasks = [tool, posture, vehicle]
    out = np.empty(cycles)
    n = len(qs)
    for k in range(cycles):
        t0 = time.perf_counter()
        config.update(qs[k % n])
        velocity = pink.solve_ik(config, tasks, 0.01, solver="daqp", safety_break=False)
        out[k] = time.perf_counter() - t0
    assert np.all(np.isfinite(velocity))
    return out * 1e6


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--cycles", type=int, default=3000)
    args = parser.parse_args()
    model = UvmsModel.load()
    actions = load_actions(model=model)
    states, goal = grasp_states(model, actions, 600)
    gc.disable()
    try:
        time_ours(model, actions, states, goal, 200)  # warm-up
        full, solves, arm = time_ours(model, actions, states, goal, args.cycles)
        time_pink(actions, states, goal, 200)
        pink_t = time_pink(actions, states, goal, args.cycles)
    finally:
        gc.enable()
    med, p99 = float(np.median(full)), float(np.percentile(full, 99))
    pink_med = float(np.median(pink_t))
    print(f"grasp action: {len(actions.tasks_of('grasp'))} tasks, n = {model.n} (l = {model.n_joints} joints + 6 vehicle DOFs), {args.cycles} cycles")
    print(f"full cycle (kinematics + TPIK 1 + TPIK 2): median {med:.0f} us, p99 {p99:.0f} us")
    print(f"  of which the two TPIK solves:            median {np.median(solves):.0f} us (the rest: kinematics, tasks, stacking)")
    print(f"arm_step alone (kinematics + TPIK 2):     median {np.median(arm):.0f} us, p99 {np.percentile(arm, 99):.0f} us")
    print(f"pink (update + weighted QP, daqp):          median {pink_med:.0f} us, p99 {np.percentile(pink_t, 99):.0f} us")
    print(f"kcl_cycle median_us={med:.0f} p99_us={p99:.0f} pink_us={pink_med:.0f} ratio={med / pink_med:.2f}")


if __name__ == "__main__":
    main()
