"""The controller's stacking shortcuts change nothing: restoring last cycle's
level layout (kcl.stacking: same tasks skipped as last cycle) and deriving
TPIK 2's stack from TPIK 1's give bit-for-bit the outputs of a controller
that rebuilds every level every cycle, while tasks keep activating and
deactivating (joint limits, altitude, attitude, manipulability bands)."""

from __future__ import annotations

import numpy as np
import pytest

from kcl.actions import load_actions
from kcl.controller import ControllerConfig, MeasuredState, UvmsController
from kcl.model import UvmsModel


class _NoMemo(dict):
    """A memo table that never remembers anything."""

    def get(self, key, default=None):
        return default

    def __setitem__(self, key, value):
        pass


@pytest.fixture(scope="module")
def model() -> UvmsModel:
    return UvmsModel.load()


def _states(model: UvmsModel, rng: np.random.Generator, n: int) -> list[MeasuredState]:
    """A wandering state whose joints, altitude and attitude cross their task bands."""
    lo, hi = model.joint_lower, model.joint_upper
    states = []
    for k in range(n):
        phase = 2 * np.pi * k / n
        # each joint sweeps between the middle and just inside its upper limit band
        q = 0.5 * (lo + hi) + (0.5 * (hi - lo) - 0.1) * (0.5 + 0.5 * np.sin(phase + np.arange(model.n_joints)))
        q = q + rng.normal(0, 0.01, model.n_joints)
        eta = np.array([0.1 * np.sin(phase), 0.0, 10.0, 0.03 * np.sin(3 * phase), 0.03 * np.cos(2 * phase), 0.3])
        altitude = 0.8 + 0.3 * np.sin(5 * phase)
        v = rng.normal(0, 0.02, 6) if k % 7 else None  # a few steps without a velocity measurement
        states.append(MeasuredState(q, eta, v, 0.0, altitude))
    return states


@pytest.mark.parametrize("actuated", [(True,) * 6, (True, True, True, False, False, True)])
def test_reused_levels_equal_rebuilt_levels(model, actuated):
    actions = load_actions(model=model)
    config = ControllerConfig(actuated_dofs=actuated)
    fast, slow = UvmsController(model, actions, config), UvmsController(model, actions, config)
    slow._level_memos = _NoMemo()
    q0 = np.array(actions.postures["grasp_ready"], dtype=float)
    goal = model.frame_pose_world(q0, np.array([0, 0, 10.0, 0, 0, 0.3]), "tool")
    camera = goal[:3, 3] + np.array([0.0, 0.3, -0.2])
    for ctrl in (fast, slow):
        ctrl.set_targets(tool_goal=goal, camera_target=camera)
        ctrl.set_action("grasp", 0.0)
    rng = np.random.default_rng(3)
    patterns = set()
    for k, s in enumerate(_states(model, rng, 240)):
        t = 1.0 + 0.01 * k
        meas = MeasuredState(s.q, s.eta, s.v, t, s.altitude)
        if k % 3 == 2:  # an arm step alone at another instant: TPIK 2 stacked on its own
            out_fast, out_slow = fast.arm_step(meas, t), slow.arm_step(meas, t)
        else:
            out_fast, out_slow = fast.step(meas, t), slow.step(meas, t)
        slow._derive_memo = None
        assert np.array_equal(np.hstack(out_fast), np.hstack(out_slow)), k
        patterns.add((fast._stack1.count, fast._stack2.count))
    assert len(patterns) >= 3  # the level layout really changed along the way


def test_one_call_arm_cycle_equals_the_step_by_step_path(model, monkeypatch):
    """The usual arm step in one compiled call (kcl.arm_cycle) gives bit for bit
    the outputs and telemetry of the step-by-step path it replaces, which is
    also what runs when that call refuses its arguments (TypeError); with the
    inputs fused in (kcl.controller_arm) or not."""
    import kcl.controller_arm
    import kcl.stacking

    actions = load_actions(model=model)
    fast, slow = UvmsController(model, actions), UvmsController(model, actions)
    q0 = np.array(actions.postures["grasp_ready"], dtype=float)
    goal = model.frame_pose_world(q0, np.array([0, 0, 10.0, 0, 0, 0.3]), "tool")
    for ctrl in (fast, slow):
        ctrl.set_targets(tool_goal=goal)
        ctrl.set_action("grasp", 0.0)
    real = kcl.stacking.arm_cycle
    used = []

    def refusing(*args):
        raise TypeError("another kind of array")

    def counted(*args):
        used.append(1)
        return real(*args)

    rng = np.random.default_rng(5)
    for k, s in enumerate(_states(model, rng, 120)):
        t = 1.0 + 0.01 * k  # steady: the transition is over
        meas = MeasuredState(s.q, s.eta, s.v, t, s.altitude)
        monkeypatch.setattr(kcl.stacking, "arm_cycle", counted)
        monkeypatch.setattr(kcl.controller_arm, "arm_cycle", counted)
        out_fast = fast.step(meas, t) if k % 10 == 0 else fast.arm_step(meas, t)
        monkeypatch.setattr(kcl.stacking, "arm_cycle", refusing)
        monkeypatch.setattr(kcl.controller_arm, "arm_cycle", refusing)
        out_slow = slow.step(meas, t) if k % 10 == 0 else slow.arm_step(meas, t)
        assert np.array_equal(np.hstack(out_fast), np.hstack(out_slow)), k
        assert fast.telemetry() == slow.telemetry(), k
    assert len(used) >= 100  # the one-call path really ran
