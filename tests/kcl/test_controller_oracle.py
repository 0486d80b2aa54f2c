"""The controller's compiled cycle against the spec, written out plainly.

For random states, actions, switch times (through transitions, switches in the
middle of one), missing measurements and underactuated vehicles, each step of
:class:`kcl.controller.UvmsController` must equal, to the oracle's tolerance,
the TPIK of icat.md built here from scratch:

* every task's rows from :meth:`Task.evaluate` (Pinocchio's frames, not the
  cycle's compiled chain), its activation times the action-transition factor of
  MARIS eq. 13 computed here from the switch times;
* TPIK 1: the measured-velocity task ``J = [0 I_6]`` on top with activation 1 on
  the non-actuated DOFs (MARIS III-B8), then the whole hierarchy, then the
  minimum-velocity level, saturated by the joint and vehicle limits
  (non-actuated DOFs unbounded); the vehicle part kept, non-actuated DOFs zeroed;
* TPIK 2 in the spec's own form (MARIS III-B9): all n columns, the
  measured-velocity task on ALL six vehicle DOFs on top (the controller solves
  the reduced problem instead, vehicle velocity on the right-hand side), the
  joint part kept;
* the velocity fed to those top tasks: the low-pass filtered measurement (the
  filter step of kcl.filters' formula, done here), or the last command;
* both solved by tests/kcl/oracle.py (full matrices, SVD), then clipped.
"""

from __future__ import annotations

import math

import numpy as np
import oracle
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from kcl.actions import ActionSet, load_actions
from kcl.controller import ControllerConfig, MeasuredState, UvmsController
from kcl.icat import Level
from kcl.model import UvmsModel
from kcl.tasks import TaskContext

TOL = 1e-9


@pytest.fixture(scope="module")
def model() -> UvmsModel:
    return UvmsModel.load()


@pytest.fixture(scope="module")
def actions(model: UvmsModel) -> ActionSet:
    return load_actions(model=model)


def spec_bell(x: float, T: float) -> float:
    """IncreasingBell(x; 0, T) as icat.md writes it."""
    if x <= 0.0:
        return 0.0
    if x >= T:
        return 1.0
    return 0.5 * math.cos(math.pi * x / T + math.pi) + 0.5


class SpecBlend:
    """a_p of every task from the switch times (MARIS eq. 13; a switch during a
    transition starts from the current factor)."""

    def __init__(self, actions: ActionSet):
        self.actions = actions
        self.T = actions.transition_time
        self.start: dict[str, float] = {}
        self.end: dict[str, float] = {}
        self.t_switch = 0.0

    def switch(self, name: str, t: float) -> None:
        wanted = set(self.actions.tasks_of(name))
        self.start = {n: self.factor(n, t) for n in self.actions.tasks}
        self.end = {n: 1.0 if n in wanted else 0.0 for n in self.actions.tasks}
        self.t_switch = t

    def factor(self, name: str, t: float) -> float:
        if name not in self.end:
            return 0.0
        s, e = self.start[name], self.end[name]
        return e if s == e else s + (e - s) * spec_bell(t - self.t_switch, self.T)


def spec_tpik(
    model: UvmsModel,
    actions: ActionSet,
    ctrl: UvmsController,
    meas: MeasuredState,
    blend: SpecBlend,
    t: float,
    v_top: np.ndarray,
    top_activation: np.ndarray,
    limits: np.ndarray,
) -> np.ndarray:
    """ydot (n,) of icat.md for the hierarchy at ``meas``, top task first."""
    n, l = model.n, model.n_joints
    kin = model.kinematics(meas.q, meas.eta)
    ctx = TaskContext(kin, ctrl.targets, meas.altitude, v_top)
    J_top = np.zeros((6, n))
    J_top[:, l:] = np.eye(6)
    levels = [Level(J_top, top_activation, v_top.copy())]
    for lv in actions.levels:
        Js, As, Xs = [], [], []
        for task in lv.tasks:
            out = task.evaluate(ctx)
            Js.append(out.J)
            As.append(out.a * blend.factor(task.name, t))
            Xs.append(out.xdot)
        levels.append(Level(np.vstack(Js), np.concatenate(As), np.concatenate(Xs), lam=lv.lam, threshold=lv.threshold))
    return oracle.tpik(levels, lam=actions.lam, threshold=actions.threshold, limits=limits, min_velocity=True)


@pytest.mark.slow  # seconds long: the full suite runs it, test-fast does not
@settings(max_examples=25, deadline=None)
@given(
    seed=st.integers(0, 2**31),
    first=st.sampled_from(["survey", "grasp", "lift", "transport", "hold"]),
    second=st.sampled_from(["survey", "grasp", "lift", "transport", "hold"]),
    switch_after=st.floats(0.05, 1.0),
    actuated=st.sampled_from([(True,) * 6, (True, True, True, False, False, True)]),
    compensation=st.booleans(),
)
def test_every_step_equals_the_spec(model, actions, seed, first, second, switch_after, actuated, compensation):
    rng = np.random.default_rng(seed)
    config = ControllerConfig(actuated_dofs=actuated, compensation=compensation)
    ctrl = UvmsController(model, actions, config)
    blend = SpecBlend(actions)
    act = np.array(actuated)
    jlim = model.joint_velocity_limit
    vlim = np.array(config.vehicle_velocity_limit)
    limits1 = np.concatenate([jlim, np.where(act, vlim, np.inf)])
    limits2 = np.concatenate([jlim, np.full(6, np.inf)])
    q0 = np.array(actions.postures["grasp_ready"])
    eta = np.array([0.0, 0.0, 10.0, *rng.uniform(-0.05, 0.05, 2), rng.uniform(-3, 3)])
    goal = model.frame_pose_world(q0 - 0.15, eta + np.r_[rng.uniform(-0.3, 0.3, 3), 0, 0, 0.2], "tool")
    ctrl.set_targets(tool_goal=goal, vehicle_goal=np.r_[eta[:3] + rng.uniform(-1, 1, 3), 0.5])
    ctrl.set_action(first, 0.0)
    blend.switch(first, 0.0)
    y: np.ndarray | None = None  # the filter state, per kcl.filters' formula
    y_t = 0.0
    w = config.filter_cutoff_rad_s
    v_cmd = np.zeros(6)
    for k in range(12):
        t = 0.1 * k
        if t >= switch_after and blend.end != {n: 1.0 if n in actions.tasks_of(second) else 0.0 for n in actions.tasks}:
            ctrl.set_action(second, t)
            blend.switch(second, t)
        q = q0 + rng.uniform(-0.4, 0.4, model.n_joints)
        q = np.clip(q, model.joint_lower, model.joint_upper)
        eta_k = eta + np.r_[rng.uniform(-0.2, 0.2, 3), rng.uniform(-0.05, 0.05, 3)]
        v = rng.uniform(-0.1, 0.1, 6) if k % 4 != 2 else None
        altitude = float(rng.uniform(0.5, 2.0)) if k % 5 != 3 else None
        meas = MeasuredState(q, eta_k, v, t, altitude)
        # TPIK 1: fed the filtered measurement (raw before the first arm step) or the last command
        v_top1 = (y if y is not None else v) if v is not None else v_cmd
        ydot1 = spec_tpik(model, actions, ctrl, meas, blend, t, np.array(v_top1), (~act).astype(float), limits1)
        want_v = np.clip(np.where(act, ydot1[model.n_joints :], 0.0), -vlim, vlim)
        got_v = ctrl.vehicle_step(meas, t)
        assert not ctrl.telemetry()["fault"]
        np.testing.assert_allclose(got_v, want_v, rtol=0, atol=TOL)
        v_cmd = got_v
        # TPIK 2 at the same state; the filter steps first
        if v is not None:
            if y is None:
                y = v.copy()
            elif t > y_t:
                y = y + (1.0 - math.exp(-w * (t - y_t))) * (v - y)
            y_t = t
        v_top2 = y if (compensation and v is not None) else v_cmd
        ydot2 = spec_tpik(model, actions, ctrl, meas, blend, t, np.array(v_top2), np.ones(6), limits2)
        want_q = np.clip(ydot2[: model.n_joints], -jlim, jlim)
        got_q = ctrl.arm_step(meas, t)
        assert not ctrl.telemetry()["fault"]
        np.testing.assert_allclose(got_q, want_q, rtol=0, atol=TOL)


def test_telemetry_reports_each_stacked_task_with_its_factor(model, actions):
    """The logged activations include a_p; a task's record is its last evaluation."""
    ctrl = UvmsController(model, actions)
    blend = SpecBlend(actions)
    q = np.array(actions.postures["grasp_ready"])
    eta = np.array([0.0, 0.0, 10.0, 0.0, 0.0, 0.3])
    ctrl.set_targets(tool_goal=model.frame_pose_world(q - 0.1, eta, "tool"))
    ctrl.set_action("hold", 0.0)
    blend.switch("hold", 0.0)
    ctrl.set_action("grasp", 1.0)
    blend.switch("grasp", 1.0)
    meas = MeasuredState(q, eta, np.zeros(6), 1.2, 1.5)
    ctrl.step(meas, 1.2)
    tel = ctrl.telemetry()
    kin = model.kinematics(q, eta)
    for name, rec in tel["tasks"].items():
        ap = blend.factor(name, 1.2)
        assert rec["a_p"] == pytest.approx(ap, abs=1e-15)
        out = actions.tasks[name].evaluate(TaskContext(kin, ctrl.targets, 1.5, np.zeros(6)))
        np.testing.assert_allclose(rec["activation"], out.a * ap, atol=1e-12)
        np.testing.assert_allclose(rec["error"], out.error, atol=1e-9)
    # tasks with a_p = 0 are not stacked: no record
    assert set(tel["tasks"]) == {n for n in actions.tasks if blend.factor(n, 1.2) > 0.0}
