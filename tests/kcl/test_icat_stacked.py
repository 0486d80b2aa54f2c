"""The controller's per-cycle solver path (kcl.icat_stacked.StackedLevels +
solve_stacked, and the kernel's fast paths) equals the straightforward
transcription kcl.icat_reference to 1e-9, refuses bad data naming the level,
and the controller's own stacks solve to the reference result."""

import math

import numpy as np
import pinocchio as pin
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from kcl import icat
from kcl import icat_reference as ref
from kcl.actions import load_actions
from kcl.controller import ControllerConfig, MeasuredState, UvmsController
from kcl.icat import Level, tpik_trace
from kcl.icat_stacked import StackedLevels, solve_stacked
from kcl.model import Kinematics, UvmsModel
from kcl.rotations import rpy_to_matrix, rpy_to_quaternion

icat.warm_up()  # compiled kernel when available (otherwise the numpy fallback is tested)

KINDS = ["plain", "rank_deficient", "tiny", "full", "some_zero", "all_zero", "unit_rows"]


def level(rng, kind, m, n):
    J = rng.standard_normal((m, n))
    a = rng.uniform(0.05, 1.0, m)
    xdot = rng.standard_normal(m)
    if kind == "rank_deficient" and m > 1:
        J[-1] = J[0] * rng.uniform(-2, 2)
    elif kind == "tiny":
        a = 10.0 ** rng.uniform(-7, -1, m)
    elif kind == "full":
        a[:] = 1.0
    elif kind == "some_zero":
        a[rng.random(m) < 0.5] = 0.0
    elif kind == "all_zero":
        a[:] = 0.0
    elif kind == "unit_rows":  # joint-like tasks: rows of the identity, fully active
        J = np.eye(n)[rng.choice(n, size=min(m, n), replace=False)]
        a = np.ones(J.shape[0])
        xdot = rng.standard_normal(J.shape[0])
    return Level(J, a, xdot, lam=float(rng.choice([1e-4, 1e-2])), threshold=float(rng.choice([1e-2, 0.1])))


def stacked(levels, n):
    stack = StackedLevels(sum(lv.J.shape[0] for lv in levels), n, len(levels))
    for k, lv in enumerate(levels):
        p, m = stack.rows_used, lv.J.shape[0]
        stack.J[p : p + m] = lv.J
        stack.a[p : p + m] = lv.a
        stack.xdot[p : p + m] = lv.xdot
        stack.close_level(m, lv.lam, lv.threshold, f"L{k}")
    return stack


@settings(max_examples=80, deadline=None)
@given(
    seed=st.integers(0, 2**32 - 1),
    dims=st.lists(st.integers(1, 8), min_size=1, max_size=7),
    kinds=st.lists(st.sampled_from(KINDS), min_size=7, max_size=7),
    n=st.integers(2, 13),
)
def test_solve_stacked_equals_reference(seed, dims, kinds, n):
    rng = np.random.default_rng(seed)
    levels = [level(rng, k, m, n) for m, k in zip(dims, kinds)]
    limits = rng.uniform(0.05, 1.5, n)
    slow = ref.tpik(levels, limits=limits, min_velocity=True)
    fast = solve_stacked(stacked(levels, n), lam=1e-4, threshold=1e-2, limits=limits)
    np.testing.assert_allclose(fast, slow, rtol=0, atol=1e-9)


def test_fully_constrained_stack_skips_the_minimum_velocity_level():
    """Rows covering every DOF with a = 1 leave Q ~ 0: the final level is skipped
    (zero increment, factor 1) and the result still equals the reference."""
    rng = np.random.default_rng(3)
    n = 7
    levels = [
        (rng.standard_normal((3, n)), np.ones(3), rng.standard_normal(3)),
        (np.eye(n), np.ones(n), rng.standard_normal(n)),
    ]
    trace = tpik_trace(levels, min_velocity=True)
    assert trace.factors[-1] == 1.0
    np.testing.assert_array_equal(trace.raw[-1], np.zeros(n))
    np.testing.assert_allclose(trace.ydot, ref.tpik(levels, min_velocity=True), rtol=0, atol=1e-9)


@pytest.mark.parametrize(
    "where, value, message",
    [
        ("J", math.nan, "level 1 (L1): J contains NaN or inf"),
        ("a", 1.5, "level 1 (L1): activation outside [0, 1]"),
        ("a", -0.1, "level 1 (L1): activation outside [0, 1]"),
        ("xdot", math.inf, "level 1 (L1): reference xdot contains NaN or inf"),
    ],
)
def test_solve_stacked_refuses_bad_data_naming_the_level(where, value, message):
    rng = np.random.default_rng(0)
    levels = [level(rng, "plain", 2, 4), level(rng, "plain", 3, 4)]
    stack = stacked(levels, 4)
    getattr(stack, where)[3] = value  # row 3 belongs to level 1
    with pytest.raises(
        ValueError, match=message.replace("[", r"\[").replace("]", r"\]").replace("(", r"\(").replace(")", r"\)")
    ):
        solve_stacked(stack, lam=1e-4, threshold=1e-2, limits=np.ones(4))


def test_compiled_manipulability_value_matches_the_determinant():
    from kcl.small_linalg import gram_sqrt_det

    rng = np.random.default_rng(1)
    for shape in ((6, 7), (6, 6), (6, 4)):
        J = rng.standard_normal(shape)
        M = J @ J.T if shape[1] >= 6 else J.T @ J
        assert gram_sqrt_det(J) == pytest.approx(math.sqrt(np.linalg.det(M)), rel=1e-10)
    assert gram_sqrt_det(np.zeros((6, 7))) == 0.0


def test_rpy_quaternion_is_the_rotation_of_rpy_to_matrix():
    rng = np.random.default_rng(2)
    for roll, pitch, yaw in rng.uniform(-3.1, 3.1, (200, 3)):
        x, y, z, w = rpy_to_quaternion(roll, pitch, yaw)
        R = pin.Quaternion(w, x, y, z).toRotationMatrix()
        np.testing.assert_allclose(R, rpy_to_matrix(roll, pitch, yaw), atol=1e-12)


@pytest.fixture(scope="module")
def model() -> UvmsModel:
    return UvmsModel.load()


def test_controller_stacks_solve_to_the_reference(model):
    """Closed-loop grasp: every TPIK 1 / TPIK 2 solution equals the reference
    transcription run on the very levels the controller stacked."""
    actions = load_actions(model=model)
    ctrl = UvmsController(model, actions, ControllerConfig())
    grasp_ready = np.array(actions.postures["grasp_ready"])
    eta = np.array([0.0, 0.0, 10.0, 0.02, -0.01, 0.4])
    goal = model.frame_pose_world(grasp_ready - 0.1, eta + np.r_[0.2, -0.1, 0.1, 0, 0, 0.2], "tool")
    ctrl.set_targets(tool_goal=goal)
    ctrl.set_action("grasp", 0.0)
    q, v = grasp_ready + 0.25, np.zeros(6)
    solved = []
    run = ctrl._run_tpik

    def checked(stack, limits):
        out = run(stack, limits)
        levels = stack.levels()
        if levels:
            slow = ref.tpik(levels, lam=ctrl._lam, threshold=ctrl._threshold, limits=limits, min_velocity=True)
            np.testing.assert_allclose(out, slow, rtol=0, atol=1e-9)
            solved.append(len(levels))
        return out

    solved_hook = ctrl._solved

    def checked_fused(stack, *args):  # TPIK 2 solved and clipped in one call (kcl.cycle, kcl.arm_cycle)
        out = solved_hook(stack, *args)
        levels = stack.levels()
        if levels:
            slow = ref.tpik(levels, lam=ctrl._lam, threshold=ctrl._threshold, limits=ctrl._jlim, min_velocity=True)
            np.testing.assert_allclose(out, np.clip(slow, -ctrl._jlim, ctrl._jlim), rtol=0, atol=1e-9)
            solved.append(len(levels))
        return out

    ctrl._run_tpik = checked
    ctrl._solved = checked_fused
    for k in range(120):  # through the action transition (a_p < 1) and after it
        t = 0.01 * k
        meas = MeasuredState(q.copy(), eta.copy(), v.copy(), t, 1.5)
        if k % 10 == 0:
            v = ctrl.vehicle_step(meas, t)
        q = q + 0.01 * ctrl.arm_step(meas, t)
    assert len(solved) >= 120 and max(solved) >= 3


@pytest.mark.parametrize("fused", [True, False])
def test_arm_step_fault_on_bad_task_rows(model, fused, monkeypatch):
    """A non-finite task row in the steady TPIK 2 gives zero joint references and
    the same fault, whether it is solved in one compiled call (kcl.cycle) or not."""
    actions = load_actions(model=model)
    ctrl = UvmsController(model, actions, ControllerConfig())
    if not ctrl._fused and fused:
        pytest.skip("compiled solver switched off")
    ctrl._fused = ctrl._fused and fused
    q = np.array(actions.postures["grasp_ready"])
    eta = np.array([0.0, 0.0, 10.0, 0.02, -0.01, 0.4])
    ctrl.set_targets(tool_goal=model.frame_pose_world(q - 0.1, eta, "tool"))
    ctrl.set_action("grasp", 0.0)
    for k in range(3):  # steady (transition over) arm steps
        t = 1.0 + 0.01 * k
        assert np.abs(ctrl.arm_step(MeasuredState(q + 0.001 * k, eta, np.zeros(6), t, 1.5), t)).max() > 0
    frames_into = Kinematics.frames_into

    def poisoned(self, *args, **kwargs):  # the frame Jacobians the task kernels read
        frames_into(self, *args, **kwargs)
        ctrl._batch.Jw[:] = np.nan
        ctrl._batch._Jraw[:] = np.nan

    monkeypatch.setattr(Kinematics, "frames_into", poisoned)
    chain = ctrl._chain
    if chain is not None:  # the arm step's compiled call computes the frames itself (kcl.kin_frames)
        ctrl._chain = (chain[0], np.full_like(chain[1], np.nan))
    out = ctrl.arm_step(MeasuredState(q + 0.01, eta, np.zeros(6), 1.1, 1.5), 1.1)
    ctrl._chain = chain
    tel = ctrl.telemetry()
    assert not out.any() and tel["fault"]
    assert (
        tel["fault_reason"].startswith("solver refused the task data: level 0 (")
        and "contains NaN or inf" in tel["fault_reason"]
    )
    monkeypatch.setattr(Kinematics, "frames_into", frames_into)
    assert np.abs(ctrl.arm_step(MeasuredState(q, eta, np.zeros(6), 1.2, 1.5), 1.2)).max() > 0
    assert not ctrl.telemetry()["fault"]
