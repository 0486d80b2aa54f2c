"""UvmsController.status(): the telemetry fields the mission tree reads every
tick, equal to telemetry()'s (before any action, in a transition, converging,
after a fault, stopped); a telemetry snapshot's message built steps later is
the message of the step that took it."""

from __future__ import annotations

import numpy as np

from kcl.actions import load_actions
from kcl.controller import ControllerConfig, MeasuredState, UvmsController
from kcl.model import UvmsModel
from kcl.telemetry import STATUS_KEYS, controller_status


def _same(ctrl: UvmsController) -> None:
    tel, st = ctrl.telemetry(), ctrl.status()
    assert set(st) == set(STATUS_KEYS)
    assert st == {k: tel[k] for k in STATUS_KEYS}
    assert controller_status(ctrl) == st


def test_status_matches_telemetry() -> None:
    model = UvmsModel.load()
    actions = load_actions(model=model)
    ctrl = UvmsController(model, actions, ControllerConfig())
    _same(ctrl)  # no action yet
    q = np.array(actions.postures["grasp_ready"])
    eta = np.array([0.0, 0.0, 10.0, 0.0, 0.0, 0.0])
    ctrl.set_action("transport", 0.0)
    _same(ctrl)
    t, v = 0.0, np.zeros(6)
    for k in range(400):
        meas = MeasuredState(q, eta, v.copy(), t, altitude=1.3)
        if k % 10 == 0:
            v = ctrl.vehicle_step(meas, t)
        q = q + ctrl.arm_step(meas, t) * 0.01
        t += 0.01
        if k % 37 == 0:
            _same(ctrl)
    assert ctrl.status()["convergence"] is not None
    bad = MeasuredState(np.r_[q[:-1], np.nan], eta, None, t)
    ctrl.arm_step(bad, t)
    assert ctrl.status()["fault"]
    _same(ctrl)
    ctrl.stop(t)
    _same(ctrl)


def test_snapshot_message_is_that_of_its_step() -> None:
    """The runtime builds the /kcl message one step after taking the snapshot: the
    steps in between (new rows, new commands, an action switch, a fault) must not
    leak into it."""
    model = UvmsModel.load()
    actions = load_actions(model=model)
    ctrl = UvmsController(model, actions, ControllerConfig())
    q = np.array(actions.postures["grasp_ready"])
    eta = np.array([0.0, 0.0, 10.0, 0.0, 0.0, 0.0])
    ctrl.set_action("transport", 0.0)
    t, v = 0.0, np.zeros(6)
    taken: list[tuple[object, dict]] = []
    for k in range(120):
        meas = MeasuredState(q, eta, v.copy(), t, altitude=1.3)
        if k % 10 == 0:
            v = ctrl.vehicle_step(meas, t)
        q = q + ctrl.arm_step(meas, t) * 0.01
        t += 0.01
        if k % 10 == 5:
            taken.append((ctrl.telemetry_snapshot(), ctrl.telemetry()))
        if k == 60:
            ctrl.set_action("grasp", t)
    ctrl.arm_step(MeasuredState(np.r_[q[:-1], np.nan], eta, None, t), t)
    assert ctrl.telemetry()["fault"]
    messages = [snap.message() for snap, _ in taken]  # type: ignore[attr-defined]
    assert {m["action"] for m in messages} == {"transport", "grasp"}
    for message, (_, then) in zip(messages, taken):
        assert message == then
        assert not message["fault"]


class _TelemetryOnly:
    def telemetry(self) -> dict:
        return {"action": "x", "fault": False}


def test_controller_status_falls_back_to_telemetry() -> None:
    assert controller_status(_TelemetryOnly()) == {"action": "x", "fault": False}
