"""The compiled helpers of the task kernels against their mathematics, and the
controller's cycle compiled once for all steps."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from kcl.actions import load_actions
from kcl.controller import MeasuredState, UvmsController
from kcl.cycle import tpik_cycle
from kcl.model import UvmsModel
from kcl.rotations import so3_exp
from kcl.tasks import TASK_TYPES, Targets, TaskContext
from kcl.tasks.batch import KERNEL_INDEX, ROW_KERNELS
from kcl.tasks.jit import IDLE_NOTES, saturate_into
from kcl.tasks.tool_orientation import so3_log_into


@pytest.fixture(scope="module")
def model() -> UvmsModel:
    return UvmsModel.load()


def test_every_task_type_has_its_kernel_in_the_dispatch() -> None:
    assert len(ROW_KERNELS) == len(TASK_TYPES) == len(KERNEL_INDEX)
    for name, cls in TASK_TYPES.items():
        assert ROW_KERNELS[KERNEL_INDEX[name]] is cls.ROW_KERNEL


def test_so3_log_kernel_inverts_the_exponential() -> None:
    """exp(log(R)) = R and log(exp(w)) = w for rotation angles in [0, pi), near 0
    and near pi too (where the logarithm is ill-conditioned)."""
    rng = np.random.default_rng(7)
    out = np.empty(3)
    vectors = [rng.normal(0, 1.0, 3) for _ in range(100)]
    for _ in range(50):
        axis = rng.normal(size=3)
        axis /= np.linalg.norm(axis)
        vectors.append(axis * rng.uniform(0, 1e-7))
        vectors.append(axis * (np.pi - rng.uniform(1e-4, 5e-3)))
    for w in vectors:
        angle = np.linalg.norm(w)
        if angle >= np.pi:
            w = w * (1.0 - 2.0 * np.pi / angle)  # the same rotation, angle in (-pi, pi)
        R = so3_exp(w)
        so3_log_into(R, out)
        tol = 1e-12 if np.linalg.norm(w) < 3.0 else 1e-7  # acos-based: ~1e-8 within 5e-3 of pi
        np.testing.assert_allclose(so3_exp(out), R, rtol=0, atol=tol)
        np.testing.assert_allclose(out, w, rtol=0, atol=tol)
    so3_log_into(so3_exp(np.array([np.pi, 0.0, 0.0])), out)
    assert abs(abs(out[0]) - np.pi) < 1e-12 and not out[1:].any()


@settings(max_examples=200, deadline=None)
@given(
    err=st.lists(st.floats(-10, 10), min_size=1, max_size=6),
    gain=st.floats(0.01, 5.0),
    limit=st.sampled_from([0.05, 0.5, 5.0, math.inf]),
)
def test_saturation_keeps_the_direction_within_the_limit(err, gain, limit) -> None:
    e = np.array(err)
    out = np.empty_like(e)
    saturate_into(out, e, gain, limit)
    assert np.max(np.abs(out)) <= limit * (1 + 1e-15)
    raw = gain * e
    if np.max(np.abs(raw)) <= limit:
        np.testing.assert_array_equal(out, raw)
    else:  # a uniform scaling: the same direction
        s = limit / np.max(np.abs(raw))
        np.testing.assert_allclose(out, raw * s, rtol=1e-15, atol=0)


def test_manipulability_gradient_is_the_finite_difference(model: UvmsModel) -> None:
    rng = np.random.default_rng(11)
    h = 1e-6
    for _ in range(10):
        q = rng.uniform(model.joint_lower + 0.1, model.joint_upper - 0.1)
        mu, grad = model.kinematics(q, np.zeros(6)).manipulability("tool")
        fd = np.array(
            [
                (
                    model.kinematics(q + h * e, np.zeros(6)).manipulability("tool")[0]
                    - model.kinematics(q - h * e, np.zeros(6)).manipulability("tool")[0]
                )
                / (2 * h)
                for e in np.eye(model.n_joints)
            ]
        )
        np.testing.assert_allclose(grad, fd, rtol=1e-5, atol=1e-8)
        M = model.kinematics(q, np.zeros(6)).arm_jacobian("tool")
        assert mu == pytest.approx(math.sqrt(np.linalg.det(M @ M.T)), rel=1e-9)


def test_idle_tasks_say_why(model: UvmsModel) -> None:
    actions = load_actions(model=model)
    kin = model.kinematics(model.neutral(), np.zeros(6))
    notes = {name: task.evaluate(TaskContext(kin, Targets(), None)).note for name, task in actions.tasks.items()}
    assert notes["altitude"] == IDLE_NOTES[3] and notes["tool_position"] == "no tool_goal"
    assert notes["camera_centering"] == "no camera target" and notes["waypoint"] == "no vehicle_goal"
    assert notes["joint_limits"] == "" and notes["arm_stop"] == ""
    for name, task in actions.tasks.items():
        out = task.evaluate(TaskContext(kin, Targets(), None))
        assert not out.note or not out.a.any(), name


def test_the_cycle_never_compiles_after_the_constructor(model: UvmsModel) -> None:
    """Every input of the cycle keeps the types of the constructor's warm-up, in
    every action, with and without measurements: a control cycle never triggers a
    Numba compilation (the dispatcher is locked: one would raise)."""
    actions = load_actions(model=model)
    ctrl = UvmsController(model, actions)
    before = list(tpik_cycle.signatures)
    assert len(before) == 1
    rng = np.random.default_rng(5)
    q = model.neutral()
    eta = np.r_[0.0, 0.0, 5.0, 0.0, 0.0, 0.3]
    ctrl.set_targets(tool_goal=model.frame_pose_world(q, eta, "tool"), vehicle_goal=np.r_[eta[:3] + 1.0, 0.3])
    for k, action in enumerate(("survey", "grasp", "transport", "hold")):
        ctrl.set_action(action, float(k))
        for i in range(5):
            t = k + 0.2 * i
            v = None if i % 2 else rng.normal(0, 0.1, 6)
            meas = MeasuredState(q + 0.01 * i, list(eta), v, t, 2 if i % 2 else None)  # (a list, an int)
            ctrl.step(meas, t)
            ctrl.arm_step(meas, t + 0.01)
    ctrl.stop(10.0)
    ctrl.arm_step(MeasuredState(q, eta, np.zeros(6), 10.5, 1.0), 10.5)
    assert list(tpik_cycle.signatures) == before
