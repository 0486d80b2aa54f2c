"""The fused arm step (kcl.controller_arm) gives the step by step path's
results bit for bit: references, telemetry and the state both leave, over a
closed loop with action switches, a non-finite input and a velocity loss."""

from __future__ import annotations

import numpy as np

from kcl.actions import load_actions
from kcl.controller import ControllerConfig, MeasuredState, UvmsController
from kcl.model import UvmsModel
from kcl.stacking import UNSOLVED


def _run(model, actions, fused: bool) -> tuple[list, int]:
    ctrl = UvmsController(model, actions, ControllerConfig())
    hits = [0]
    if not fused:
        ctrl._arm_fused = lambda meas, t: UNSOLVED
    else:
        inner = ctrl._arm_fused

        def counted(meas, t):
            out = inner(meas, t)
            hits[0] += out is not UNSOLVED
            return out

        ctrl._arm_fused = counted
    q = np.array(actions.postures["grasp_ready"])
    eta = np.array([0.0, 0.0, 10.0, 0.01, -0.02, 0.3])
    ctrl.set_targets(tool_goal=model.frame_pose_world(q - 0.1, eta, "tool"))
    ctrl.set_action("transport", 0.0)
    rng = np.random.default_rng(4)
    t, v, out = 0.0, np.zeros(6), []
    for k in range(500):
        if k == 200:
            ctrl.set_action("grasp", t)
        vm = None if 300 <= k < 320 else v + rng.normal(0, 0.01, 6)
        qm = np.r_[q[:-1], np.nan] if k == 350 else q
        meas = MeasuredState(qm, eta, vm, t, altitude=1.2 + 0.001 * k)
        if k % 10 == 0:
            v = ctrl.vehicle_step(meas, t)
        qdot = ctrl.arm_step(meas, t)
        out.append((qdot, ctrl.telemetry()))
        q = q + qdot * 0.01
        eta = eta + 0.01 * np.r_[v[:3], 0.0, 0.0, v[5]]
        t += 0.01
    return out, hits[0]


def test_fused_arm_step_is_bit_for_bit() -> None:
    model = UvmsModel.load()
    actions = load_actions(model=model)
    a, _ = _run(model, actions, fused=False)
    b, hits = _run(model, actions, fused=True)
    assert hits > 300
    for (qa, ta), (qb, tb) in zip(a, b):
        assert np.array_equal(qa, qb)
        assert ta == tb
