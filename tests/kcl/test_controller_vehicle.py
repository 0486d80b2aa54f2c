"""The fused vehicle step (kcl.controller_vehicle) gives the step by step path's
results bit for bit: references, telemetry and the arm steps that follow, over a
closed loop through every action (waypoint, vehicle stop, arm tasks), with all
DOFs actuated or roll and pitch not, a non-finite input and a velocity loss."""

from __future__ import annotations

import numpy as np
import pytest
from kcltest_util import count_fused

from kcl.actions import load_actions
from kcl.controller import ControllerConfig, MeasuredState, UvmsController
from kcl.model import UvmsModel
from kcl.stacking import UNSOLVED

UNDERACTUATED = (True, True, True, False, False, True)


@pytest.fixture(scope="module")
def model() -> UvmsModel:
    return UvmsModel.load()


def _run(model, actions, fused: bool, actuated: tuple[bool, ...]) -> tuple[list, int]:
    ctrl = UvmsController(model, actions, ControllerConfig(actuated_dofs=actuated))
    hits = count_fused(ctrl, "_vehicle_fused", fused)
    q = np.array(actions.postures["survey_folded"])
    eta = np.array([0.0, 0.0, 9.0, 0.01, -0.02, 0.3])
    ctrl.set_targets(
        vehicle_goal=np.array([2.0, -1.0, 9.5, 1.0]),
        tool_goal=model.frame_pose_world(np.array(actions.postures["grasp_ready"]) - 0.1, eta, "tool"),
    )
    ctrl.set_action("survey", 0.0)
    rng = np.random.default_rng(6)
    t, v, out = 0.0, np.zeros(6), []
    plan = {150: "hold", 300: "grasp", 450: "lift", 600: "transport"}
    for k in range(750):
        if k in plan:
            ctrl.set_action(plan[k], t)
        vm = None if 500 <= k < 530 else v + rng.normal(0, 0.01, 6)
        qm = np.r_[q[:-1], np.nan] if k == 380 else q
        meas = MeasuredState(qm, eta, vm, t, altitude=None if 200 <= k < 220 else 1.5 + 0.001 * k)
        if k % 10 == 0:
            v = ctrl.vehicle_step(meas, t)
            out.append(("vehicle", v, ctrl.telemetry()))
        qdot = ctrl.arm_step(meas, t)
        out.append(("arm", qdot, ctrl.telemetry()))
        q = q + qdot * 0.01
        eta = eta + 0.01 * np.r_[v[:3], v[3:5] * 0.1, v[5]]
        t += 0.01
    return out, hits[0]


@pytest.mark.parametrize("actuated", [(True,) * 6, UNDERACTUATED], ids=["all", "no_roll_pitch"])
def test_fused_vehicle_step_is_bit_for_bit(model, actuated) -> None:
    actions = load_actions(model=model)
    a, _ = _run(model, actions, False, actuated)
    b, hits = _run(model, actions, True, actuated)
    assert hits > 40  # of 75 vehicle steps: the transitions, the first steady step, the NaN take the other path
    assert len(a) == len(b)
    for (ka, va, ta), (kb, vb, tb) in zip(a, b):
        assert ka == kb
        assert np.array_equal(va, vb), (ka, ta["t"])
        assert ta == tb, (ka, ta["t"])


def test_fused_vehicle_step_reports_a_non_finite_input(model) -> None:
    """A NaN joint position: the fused call declines, the step by step path gives zeros and the fault."""
    actions = load_actions(model=model)
    ctrl = UvmsController(model, actions, ControllerConfig())
    q = np.array(actions.postures["transport"])
    eta = np.array([0.0, 0.0, 9.0, 0.0, 0.0, 0.0])
    ctrl.set_action("hold", 0.0)
    for k in range(80):  # past the transition (a new state each step): the steady plan's layout exists
        q = q + 1e-4
        meas = MeasuredState(q, eta, np.zeros(6), 0.01 * k, 1.5)
        if k % 10 == 0:
            ctrl.vehicle_step(meas, 0.01 * k)
        ctrl.arm_step(meas, 0.01 * k)
    assert ctrl._vehicle_fused(MeasuredState(q, eta, np.zeros(6), 0.8, 1.5), 0.8) is not UNSOLVED
    bad = MeasuredState(np.r_[q[:-1], np.nan], eta, np.zeros(6), 0.81, 1.5)
    assert ctrl._vehicle_fused(bad, 0.81) is UNSOLVED
    v = ctrl.vehicle_step(bad, 0.81)
    assert np.array_equal(v, np.zeros(6))
    tm = ctrl.telemetry()
    assert tm["fault"] and "non-finite" in tm["fault_reason"]
