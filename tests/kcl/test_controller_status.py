"""UvmsController.status(): the telemetry fields the mission tree reads every
tick, equal to telemetry()'s (before any action, in a transition, converging,
after a fault, stopped); a telemetry snapshot's message built steps later is
the message of the step that took it."""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from kcl.actions import load_actions
from kcl.controller import ControllerConfig, MeasuredState, UvmsController
from kcl.model import UvmsModel
from kcl.telemetry import STATUS_KEYS, TelemetrySnapshot, controller_status


def _same(ctrl: UvmsController) -> None:
    tel, st = ctrl.telemetry(), ctrl.status()
    assert set(st) == set(STATUS_KEYS)
    assert st == {k: tel[k] for k in STATUS_KEYS}
    assert controller_status(ctrl) == st


ETA = np.array([0.0, 0.0, 10.0, 0.0, 0.0, 0.0])


def _controller() -> tuple[UvmsController, np.ndarray]:
    model = UvmsModel.load()
    actions = load_actions(model=model)
    return UvmsController(model, actions, ControllerConfig()), np.array(actions.postures["grasp_ready"])


def _steps(
    ctrl: UvmsController, q: np.ndarray, count: int, after: Callable[[int, float], None]
) -> tuple[np.ndarray, float]:
    """``count`` arm steps of 10 ms (the vehicle every tenth) from ``q`` at time 0, in
    closed loop on the joints; ``after(k, t)`` after each. Returns the last q and t."""
    t, v = 0.0, np.zeros(6)
    for k in range(count):
        meas = MeasuredState(q, ETA, v.copy(), t, altitude=1.3)
        if k % 10 == 0:
            v = ctrl.vehicle_step(meas, t)
        q = q + ctrl.arm_step(meas, t) * 0.01
        t += 0.01
        after(k, t)
    return q, t


def test_status_matches_telemetry() -> None:
    ctrl, q = _controller()
    _same(ctrl)  # no action yet
    ctrl.set_action("transport", 0.0)
    _same(ctrl)
    q, t = _steps(ctrl, q, 400, lambda k, t: _same(ctrl) if k % 37 == 0 else None)
    assert ctrl.status()["convergence"] is not None
    bad = MeasuredState(np.r_[q[:-1], np.nan], ETA, None, t)
    ctrl.arm_step(bad, t)
    assert ctrl.status()["fault"]
    _same(ctrl)
    ctrl.stop(t)
    _same(ctrl)


def test_snapshot_message_is_that_of_its_step() -> None:
    """The runtime builds the /kcl message one step after taking the snapshot: the
    steps in between (new rows, new commands, an action switch, a fault) must not
    leak into it."""
    ctrl, q = _controller()
    ctrl.set_action("transport", 0.0)
    taken: list[tuple[TelemetrySnapshot, dict]] = []

    def after(k: int, t: float) -> None:
        if k % 10 == 5:
            taken.append((ctrl.telemetry_snapshot(), ctrl.telemetry()))
        if k == 60:
            ctrl.set_action("grasp", t)

    q, t = _steps(ctrl, q, 120, after)
    ctrl.arm_step(MeasuredState(np.r_[q[:-1], np.nan], ETA, None, t), t)
    assert ctrl.telemetry()["fault"]
    messages = [snap.message() for snap, _ in taken]
    assert {m["action"] for m in messages} == {"transport", "grasp"}
    for message, (_, then) in zip(messages, taken):
        assert message == then
        assert not message["fault"]


class _TelemetryOnly:
    def telemetry(self) -> dict:
        return {"action": "x", "fault": False}


def test_controller_status_falls_back_to_telemetry() -> None:
    assert controller_status(_TelemetryOnly()) == {"action": "x", "fault": False}
