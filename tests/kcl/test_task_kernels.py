"""Compiled task kernels: the controller's batch (kcl.tasks.batch) gives exactly
what each task's own ``evaluate`` gives (the code the finite-difference tests of
test_tasks.py check), idle notes survive the batch, and the compiled helpers
match their Python originals (so3_log, saturate)."""

from __future__ import annotations

import numpy as np
import pytest

from kcl.model import UvmsModel
from kcl.rotations import so3_exp, so3_log
from kcl.tasks import (
    ArmJointLimits,
    ArmManipulability,
    ArmPreferredShape,
    ArmVelocityMinimization,
    CameraCentering,
    ElbowCameraOcclusion,
    Targets,
    TaskContext,
    ToolOrientation,
    ToolPosition,
    VehicleAltitude,
    VehicleHorizontalAttitude,
    VehiclePositionHeading,
    VehicleVelocityMinimization,
    saturate,
)
from kcl.tasks.batch import TaskBatch
from kcl.tasks.jit import saturate_into
from kcl.tasks.tool_orientation import so3_log_into


@pytest.fixture(scope="module")
def model() -> UvmsModel:
    return UvmsModel.load()


def compiled_tasks(model: UvmsModel):
    return [
        VehicleAltitude("alt", model, min_altitude=1.0, width=2.0),
        VehicleHorizontalAttitude("att", model, max_angle=0.2, width=0.15),
        ArmJointLimits("jl", model, width=0.4),
        ArmManipulability("mu", model, mu_min=0.05, width=0.3),
        ElbowCameraOcclusion("occ", model, min_distance=0.5, width=0.5),
        CameraCentering("cam", model, max_angle=0.3, width=0.25),
        ToolPosition("pos", model, max_rate=0.05),
        ToolOrientation("ori", model, max_rate=0.1),
        ArmPreferredShape("shape", model, posture=[0.0, 0.5, None, 1.2, 0.0, None, 0.0], max_rate=0.1),
        ArmVelocityMinimization("astop", model),  # a velocity task with a row kernel (its evaluate is Python)
        VehicleVelocityMinimization("vstop", model),  # the same, on the vehicle (value: the fed velocity)
        VehiclePositionHeading("wp", model, max_rate=0.2, max_yaw_rate=0.1),  # (evaluate is Python too)
    ]


def random_state(model: UvmsModel, rng: np.random.Generator):
    q = rng.uniform(model.joint_lower, model.joint_upper)
    eta = np.r_[rng.normal(0, 2, 3), rng.uniform(-0.3, 0.3, 2), rng.uniform(-3, 3)]
    goal = np.eye(4)
    goal[:3, :3] = so3_exp(rng.normal(0, 1.5, 3))
    goal[:3, 3] = eta[:3] + rng.normal(0, 1.0, 3)
    return q, eta, goal


def test_every_compiled_task_is_in_the_batch(model: UvmsModel) -> None:
    tasks = compiled_tasks(model)
    batch = TaskBatch(tasks, model.n)
    assert [t.name for t in batch.tasks] == [t.name for t in tasks]
    assert len({t.KERNEL_ID for t in tasks}) == len(tasks)


@pytest.mark.parametrize("seed", range(25))
def test_batch_equals_each_task_evaluate(model: UvmsModel, seed: int) -> None:
    rng = np.random.default_rng(seed)
    tasks = compiled_tasks(model)
    batch = TaskBatch(tasks, model.n)
    q, eta, goal = random_state(model, rng)
    camera_target = None if seed % 3 else goal[:3, 3] + rng.normal(0, 0.5, 3)
    vehicle_goal = np.r_[eta[:3] + rng.normal(0, 1.0, 3), rng.uniform(-4, 4)]  # (yaw errors past pi: wrapped)
    targets = Targets(tool_goal=goal, camera_target=camera_target, vehicle_goal=vehicle_goal)
    altitude = float(rng.uniform(0.5, 4.0))
    velocity = rng.normal(0, 0.3, 6) if seed % 2 else None
    kin = model.kinematics(q, eta)
    # select a random subset: unselected rows must keep their previous content
    batch.selected[:] = True
    batch.run(kin, targets, altitude)
    before = batch.J.copy()
    pick = rng.random(len(tasks)) < 0.6
    q2, eta2, _ = random_state(model, rng)
    kin2 = model.kinematics(q2, eta2)
    batch.selected[:] = pick
    frames = set().union(*(batch.task_frames[k] for k in np.flatnonzero(pick)))
    batch.run(kin2, targets, altitude, frames, velocity)
    for k, task in enumerate(tasks):
        if pick[k]:
            ref = task.evaluate(TaskContext(model.kinematics(q2, eta2), targets, altitude, velocity))
            out = batch.output(k)
            assert out.note == ref.note == ""
            for field in ("x", "J", "a", "xdot", "error"):
                np.testing.assert_allclose(
                    getattr(out, field), getattr(ref, field), rtol=0, atol=1e-12, err_msg=f"{task.name}.{field}"
                )
        else:
            s = slice(batch.row0[k], batch.row0[k] + batch.dims[k])
            np.testing.assert_array_equal(batch.J[s], before[s])


def test_idle_notes_through_the_batch(model: UvmsModel) -> None:
    tasks = compiled_tasks(model)
    batch = TaskBatch(tasks, model.n)
    kin = model.kinematics(model.neutral(), np.zeros(6))
    batch.selected[:] = True
    batch.run(kin, Targets(), None)
    notes = {t.name: batch.output(k).note for k, t in enumerate(tasks)}
    assert notes == {
        "alt": "no altitude measurement",
        "att": "",
        "jl": "",
        "mu": "",
        "occ": "no camera target",
        "cam": "no camera target",
        "pos": "no tool_goal",
        "ori": "no tool_goal",
        "shape": "",
        "astop": "",
        "vstop": "",
        "wp": "no vehicle_goal",
    }
    for k, t in enumerate(tasks):
        ref = t.evaluate(TaskContext(kin, Targets(), None))
        assert batch.output(k).note == ref.note
        assert not batch.output(k).a.any() or not ref.note


def test_so3_log_kernel_matches_python() -> None:
    rng = np.random.default_rng(7)
    out = np.empty(3)
    vectors = [rng.normal(0, 1.0, 3) for _ in range(100)]
    for _ in range(50):  # near 0 and near pi (both branches)
        axis = rng.normal(size=3)
        axis /= np.linalg.norm(axis)
        vectors.append(axis * rng.uniform(0, 1e-7))
        vectors.append(axis * (np.pi - rng.uniform(0, 5e-5)))
    vectors.append(np.array([np.pi, 0.0, 0.0]))
    for w in vectors:
        R = so3_exp(w)
        so3_log_into(R, out)
        np.testing.assert_allclose(out, so3_log(R), rtol=0, atol=1e-12)


def test_saturate_kernel_matches_python() -> None:
    rng = np.random.default_rng(3)
    out = np.empty(4)
    for _ in range(200):
        err = rng.normal(0, 1, 4)
        gain, limit = rng.uniform(0.1, 2.0), float(rng.choice([0.05, 0.5, 5.0, np.inf]))
        saturate_into(out, err, gain, limit)
        np.testing.assert_allclose(out, saturate(gain * err, limit), rtol=0, atol=1e-15)


def test_manipulability_kernel_matches_model_gradient(model: UvmsModel) -> None:
    """The task kernel's gradient is the model's analytic one (itself checked
    against finite differences in test_model.py), wherever the task is active."""
    task = ArmManipulability("mu", model, mu_min=0.05, width=0.3)
    rng = np.random.default_rng(11)
    active = 0
    for _ in range(30):
        q, eta, _goal = random_state(model, rng)
        kin = model.kinematics(q, eta)
        out = task.evaluate(TaskContext(kin, Targets(), None))
        mu, grad = model.kinematics(q, eta).manipulability("tool")
        assert out.x[0] == pytest.approx(mu, abs=1e-12)
        if out.a[0] > 0.0:
            active += 1
            np.testing.assert_allclose(out.J[0, : model.n_joints], grad, rtol=0, atol=1e-12)
            assert not out.J[0, model.n_joints :].any()
    assert active >= 10


def test_controller_cycles_never_compile(model: UvmsModel) -> None:
    """All batch inputs keep the types of the constructor's warm-up: a control
    cycle never triggers a Numba compilation (no signature added after the
    constructor). With an empty cache, compiling a kernel that calls another
    (e.g. kcl.arm_cycle) also lists the callee's own signatures on the callee's
    dispatcher, so the count right after the warm-up may exceed one."""
    from kcl.actions import load_actions
    from kcl.arm_cycle import arm_cycle
    from kcl.controller import MeasuredState, UvmsController
    from kcl.cycle import gather_solve
    from kcl.tasks.batch import copy_arm_rows, gather_rows, run_rows
    from kcl.tasks.jit import HAVE_NUMBA
    from kcl.vehicle_cycle import vehicle_cycle

    if not HAVE_NUMBA:
        pytest.skip("Numba not installed")
    actions = load_actions(model=model)
    ctrl = UvmsController(model, actions)
    kernels = (run_rows, gather_rows, copy_arm_rows, gather_solve, arm_cycle, vehicle_cycle)
    before = [list(k.signatures) for k in kernels]
    fills, arm_cycles = [], []  # arm_only of each compiled stacking; compiled TPIK 2 cycles
    fill_compiled, arm_cycle_of = ctrl._fill_compiled, ctrl._arm_cycle
    ctrl._fill_compiled = lambda *args: (fills.append(args[3]), fill_compiled(*args))[1]
    ctrl._arm_cycle = lambda *args: (arm_cycles.append(args[4]), arm_cycle_of(*args))[1]
    rng = np.random.default_rng(5)
    q, eta, goal = random_state(model, rng)
    ctrl.set_targets(tool_goal=goal, vehicle_goal=np.r_[eta[:3] + 1.0, 0.3])
    for k, action in enumerate(("survey", "grasp", "transport", "hold")):
        ctrl.set_action(action, float(k))
        for i in range(5):
            t = k + 0.2 * i
            meas = MeasuredState(q + 0.01 * i, list(eta), None, t, 2.0 if i % 2 else None)
            if i % 2:  # the step by step path (what step() falls back to)
                reason = ctrl._check(meas)
                ctrl._vehicle_step(meas, t, reason)
                ctrl._arm_step(meas, t, reason)
            else:  # the usual one (compiled cycles, kcl.controller_vehicle / kcl.controller_arm)
                ctrl.step(meas, t)
    ctrl.set_action("grasp", 10.0)
    for i in range(6):  # arm steps alone (TPIK 2 stacked on its own), after the transition
        t = 11.0 + 0.01 * i
        meas = MeasuredState(q - 0.01 * i, eta, np.zeros(6), t, 2.0)
        if i % 2:  # the step by step path on a fresh state: its compiled cycle (kcl.arm_cycle)
            ctrl._arm_step(meas, t, ctrl._check(meas))
        else:
            ctrl.arm_step(meas, t)
    for kernel, signatures in zip(kernels, before):
        assert signatures, kernel  # loaded or compiled by the warm-up
        assert list(kernel.signatures) == signatures, kernel
    # the step by step path's compiled stacking ran for TPIK 1, its compiled cycle for TPIK 2
    assert set(fills) == {False} and arm_cycles
