"""The fused arm step (kcl.controller_arm) gives the step by step path's
results bit for bit: references, telemetry and the state both leave, over a
closed loop with action switches, a non-finite input and a velocity loss."""

from __future__ import annotations

import numpy as np
from kcltest_util import count_fused

from kcl.actions import load_actions
from kcl.controller import ControllerConfig, MeasuredState, UvmsController
from kcl.model import UvmsModel


def _loop(ctrl, q, eta, steps: int, measure, plan: dict | None = None) -> list:
    """The closed loop of these tests: vehicle step every 10 arm steps (10 ms), the
    commands integrated into the joints and the pose (roll and pitch held);
    ``measure(k, t, q, eta, v)`` builds each step's :class:`MeasuredState`, ``plan``:
    step -> action to switch to. Returns ``(qdot, telemetry)`` per arm step."""
    t, v, out = 0.0, np.zeros(6), []
    for k in range(steps):
        if plan and k in plan:
            ctrl.set_action(plan[k], t)
        meas = measure(k, t, q, eta, v)
        if k % 10 == 0:
            v = ctrl.vehicle_step(meas, t)
        qdot = ctrl.arm_step(meas, t)
        out.append((qdot, ctrl.telemetry()))
        q = q + qdot * 0.01
        eta = eta + 0.01 * np.r_[v[:3], 0.0, 0.0, v[5]]
        t += 0.01
    return out


def _grasp_ready(model, actions, fused: bool, action: str):
    """A controller (its ``_arm_fused`` counted, :func:`count_fused`) at the
    grasp-ready posture with a tool goal nearby, in ``action`` from t = 0:
    ``(ctrl, hits, q, eta)``."""
    ctrl = UvmsController(model, actions, ControllerConfig())
    hits = count_fused(ctrl, "_arm_fused", fused)
    q = np.array(actions.postures["grasp_ready"])
    eta = np.array([0.0, 0.0, 10.0, 0.01, -0.02, 0.3])
    ctrl.set_targets(tool_goal=model.frame_pose_world(q - 0.1, eta, "tool"))
    ctrl.set_action(action, 0.0)
    return ctrl, hits, q, eta


def _run(model, actions, fused: bool) -> tuple[list, int]:
    ctrl, hits, q, eta = _grasp_ready(model, actions, fused, "transport")
    rng = np.random.default_rng(4)

    def measure(k, t, q, eta, v):
        vm = None if 300 <= k < 320 else v + rng.normal(0, 0.01, 6)
        qm = np.r_[q[:-1], np.nan] if k == 350 else q
        return MeasuredState(qm, eta, vm, t, altitude=1.2 + 0.001 * k)

    return _loop(ctrl, q, eta, 500, measure, {200: "grasp"}), hits[0]


def test_fused_arm_step_is_bit_for_bit() -> None:
    model = UvmsModel.load()
    actions = load_actions(model=model)
    a, _ = _run(model, actions, fused=False)
    b, hits = _run(model, actions, fused=True)
    assert hits > 300
    for (qa, ta), (qb, tb) in zip(a, b):
        assert np.array_equal(qa, qb)
        assert ta == tb


def _hold_run(model, actions, fused: bool, action: str) -> tuple[list, int]:
    """A field-like loop: joints and pose read at 50 Hz, the arm step at 100 Hz (every
    other step sees the state of the step before, with a new velocity and time)."""
    ctrl = UvmsController(model, actions, ControllerConfig())
    hits = count_fused(ctrl, "_arm_fused", fused)
    q = np.array(actions.postures["transport"]) + 0.05
    eta = np.array([1.0, -0.5, 8.0, 0.02, -0.01, 0.4])
    ctrl.set_targets(vehicle_goal=np.array([1.2, -0.4, 8.1, 0.5]))
    ctrl.set_action(action, 0.0)
    rng = np.random.default_rng(9)
    reading = []

    def measure(k, t, q, eta, v):
        if k % 2 == 0:  # a new reading
            reading[:] = [q.copy(), eta.copy()]
        return MeasuredState(reading[0], reading[1], v + rng.normal(0, 0.01, 6), t, altitude=1.5)

    return _loop(ctrl, q, eta, 300, measure), hits[0]


def test_repeated_states_take_the_fused_path() -> None:
    """The arm step on a state seen already (after a vehicle step, or between two
    readings) runs the one compiled call too, with the step by step path's
    references to rounding and its telemetry (hold and transport: a velocity task
    on the arm, and none)."""
    model = UvmsModel.load()
    actions = load_actions(model=model)
    for action in ("hold", "transport"):
        a, _ = _hold_run(model, actions, False, action)
        b, hits = _hold_run(model, actions, True, action)
        assert hits > 0.9 * 250, (action, hits)  # past the transition: every step, the repeated ones included
        for (qa, ta), (qb, tb) in zip(a, b):
            np.testing.assert_allclose(qb, qa, rtol=0, atol=1e-13)
            assert ta.keys() == tb.keys() and ta["tasks"].keys() == tb["tasks"].keys()
            for name, task in ta["tasks"].items():
                assert task.get("note") == tb["tasks"][name].get("note"), name
                np.testing.assert_allclose(tb["tasks"][name]["error"], task["error"], rtol=0, atol=1e-12)


def _vehicle_tick_run(model, actions, fused: bool) -> tuple[list, int]:
    """Only vehicle ticks: at every step ``step()`` (vehicle_step, then arm_step at
    the same new state), never an arm step on a fresh state first."""
    ctrl, hits, q, eta = _grasp_ready(model, actions, fused, "grasp")
    rng = np.random.default_rng(12)
    t, v, out = 0.0, np.zeros(6), []
    for _k in range(150):
        v, qdot = ctrl.step(MeasuredState(q, eta, v + rng.normal(0, 0.01, 6), t, altitude=1.3), t)
        out.append((qdot, ctrl.telemetry()))
        q = q + qdot * 0.01
        eta = eta + 0.01 * np.r_[v[:3], 0.0, 0.0, v[5]]
        t += 0.01
    return out, hits[0]


def test_the_arm_step_of_a_vehicle_tick_takes_the_fused_path() -> None:
    """The arm step right after a vehicle step at the same state takes its compiled
    call from the first steady step, also when no arm step ever saw a fresh state
    (it used to wait for one to build the steady plan's layout), with the step by
    step path's references to rounding."""
    model = UvmsModel.load()
    actions = load_actions(model=model)
    a, _ = _vehicle_tick_run(model, actions, False)
    b, hits = _vehicle_tick_run(model, actions, True)
    steady = 150 - int(np.ceil(actions.transition_time / 0.01)) - 1
    assert hits >= steady, (hits, steady)
    for (qa, ta), (qb, tb) in zip(a, b):
        np.testing.assert_allclose(qb, qa, rtol=0, atol=1e-13)
        assert ta["fault"] == tb["fault"] and ta["tasks"].keys() == tb["tasks"].keys()


def test_a_goal_set_after_the_action_started_is_reported() -> None:
    """Telemetry and convergence follow a task that becomes active after the steady
    plan's compiled layout was made (it was idle then: no tool goal yet)."""
    model = UvmsModel.load()
    actions = load_actions(model=model)
    ctrl = UvmsController(model, actions, ControllerConfig())
    q = np.array(actions.postures["grasp_ready"])
    eta = np.array([0.0, 0.0, 10.0, 0.01, -0.02, 0.3])
    ctrl.set_action("grasp", 0.0)
    t = 0.0
    for k in range(150):
        if k == 120:
            ctrl.set_targets(tool_goal=model.frame_pose_world(q - 0.1, eta, "tool"))
        meas = MeasuredState(q + 1e-4 * k, eta, np.zeros(6), t, altitude=1.2)
        if k % 10 == 0:
            ctrl.vehicle_step(meas, t)
        ctrl.arm_step(meas, t)
        t += 0.01
        if k < 60:  # the transition (0.5 s); the steady plan's layout is made after it
            continue
        note = ctrl.telemetry()["tasks"]["tool_position"].get("note")
        if k < 120:
            assert note == "no tool_goal" and ctrl.convergence() == np.inf
        else:
            assert not note and np.isfinite(ctrl.convergence()), k


def _read_only_run(model, actions, read_only: bool) -> tuple[list, int, int]:
    """The grasp closed loop of :func:`_vehicle_tick_run`'s controller, its readings
    read-only or not (as the ArduSub driver and ``maris log replay`` hand them out):
    ``(out, arm one-call steps, vehicle one-call steps)``."""
    ctrl, arm_hits, q, eta = _grasp_ready(model, actions, True, "grasp")
    vehicle_hits = count_fused(ctrl, "_vehicle_fused", True)
    rng = np.random.default_rng(5)

    def reading(x):
        x = np.array(x, dtype=float)
        x.setflags(write=not read_only)
        return x

    def measure(k, t, q, eta, v):
        return MeasuredState(reading(q), reading(eta), reading(v + rng.normal(0, 0.01, 6)), t, altitude=1.3)

    return _loop(ctrl, q, eta, 150, measure), arm_hits[0], vehicle_hits[0]


def test_read_only_readings_take_the_compiled_calls() -> None:
    """Read-only measurement arrays take both one-call paths, as writable ones do,
    with the same references and telemetry bit for bit (the kernels are compiled
    for writable arrays only: each call used to fail its type match and run the
    step by step path, a replay ~4x slower)."""
    model = UvmsModel.load()
    actions = load_actions(model=model)
    a, arm_a, veh_a = _read_only_run(model, actions, read_only=False)
    b, arm_b, veh_b = _read_only_run(model, actions, read_only=True)
    assert arm_b == arm_a > 80 and veh_b == veh_a > 8
    for (qa, ta), (qb, tb) in zip(a, b):
        assert np.array_equal(qa, qb)
        assert ta == tb
