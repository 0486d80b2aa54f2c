"""Control under sensor loss: what TPIK 1's measured-velocity top task uses when
the velocity measurement drops out, and the waypoint task's uniform saturation."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from kcl.actions import load_actions
from kcl.controller import ControllerConfig, MeasuredState, UvmsController
from kcl.model import UvmsModel
from kcl.tasks import Targets, TaskContext
from kcl.tasks.vehicle_pose import VehiclePositionHeading

UNDERACTUATED = (True, True, True, False, False, True)  # BlueROV2-like: roll and pitch not actuated


@pytest.fixture(scope="module")
def model() -> UvmsModel:
    return UvmsModel.load()


@pytest.fixture(scope="module")
def actions(model):  # noqa: ANN001, ANN201
    return load_actions(model=model)


def test_top_task_uses_the_commanded_velocity_once_the_measurement_is_gone(model, actions) -> None:  # noqa: ANN001
    """The trial: roll 0.05 rad/s measured, then the velocity goes to None. The top
    task must not stay pinned to the last filtered roll rate."""
    ctrl = UvmsController(model, actions, ControllerConfig(actuated_dofs=UNDERACTUATED))
    ctrl.set_targets(vehicle_goal=np.array([1.0, 0.5, 9.0, 0.3]))
    ctrl.set_action("survey", -5.0)
    seen = []
    inner = ctrl.vehicle_step

    def spy(meas, t):  # noqa: ANN001, ANN202 - what the top task was given (StepState.v_tpik1)
        out = inner(meas, t)
        seen.append(ctrl.state.v_tpik1.copy())
        return out

    ctrl.vehicle_step = spy
    q = np.array(actions.postures["survey_folded"])
    eta = np.array([0.0, 0.0, 10.0, 0.0, 0.0, 0.0])
    rolling = np.array([0.1, 0.0, 0.0, 0.05, 0.0, 0.0])
    t = 0.0
    for _ in range(15):  # 1.5 s with a measurement: the filter settles on the roll rate
        for k in range(10):
            meas = MeasuredState(q, eta, rolling, t, 2.0)
            if k == 0:
                v_cmd = ctrl.vehicle_step(meas, t)
            ctrl.arm_step(meas, t)
            t += 0.01
    assert seen[-1][3] == pytest.approx(0.05, abs=1e-3)
    assert ctrl.telemetry()["tpik1_velocity_source"] == "measured"
    for _ in range(20):  # 2 s without one
        meas = MeasuredState(q, eta, None, t, 2.0)
        previous = v_cmd
        v_cmd = ctrl.vehicle_step(meas, t)
        for _k in range(10):
            ctrl.arm_step(meas, t)
            t += 0.01
    np.testing.assert_array_equal(seen[-1], previous)  # the last commanded velocity...
    assert seen[-1][3] == 0.0 and seen[-1][4] == 0.0  # ...which is zero on the non-actuated DOFs
    tm = ctrl.telemetry()
    assert tm["tpik1_velocity_source"] == "commanded" and tm["tpik2_velocity_source"] == "commanded"
    assert v_cmd[3] == 0.0 and np.any(v_cmd[:3] != 0)  # still steering towards the goal
    assert tm["filtered_velocity"][3] == pytest.approx(0.05, abs=1e-3)  # the filter keeps its state for the return
    meas = MeasuredState(q, eta, rolling, t, 2.0)  # the measurement is back: used again
    ctrl.arm_step(meas, t)
    ctrl.vehicle_step(meas, t)
    assert seen[-1][3] == pytest.approx(0.05, abs=1e-3) and ctrl.telemetry()["tpik1_velocity_source"] == "measured"


def waypoint_reference(model, err: np.ndarray, gain: float, max_rate: float, max_yaw_rate: float) -> np.ndarray:  # noqa: ANN001
    task = VehiclePositionHeading("wp", model, gain=gain, max_rate=max_rate, max_yaw_rate=max_yaw_rate)
    eta = np.zeros(6)
    goal = np.array([err[0], err[1], err[2], err[3]])
    return task.evaluate(TaskContext(model.kinematics(model.neutral(), eta), Targets(vehicle_goal=goal))).xdot


def test_waypoint_reference_keeps_its_direction(model) -> None:  # noqa: ANN001
    # the trial's case: error [0.5, 0, 0, 1.0] with limits 0.15 m/s and 0.15 rad/s
    xdot = waypoint_reference(model, np.array([0.5, 0.0, 0.0, 1.0]), 1.0, 0.15, 0.15)
    np.testing.assert_allclose(xdot, [0.075, 0.0, 0.0, 0.15])


@settings(max_examples=60, deadline=None)
@given(
    err=st.lists(st.floats(-3.0, 3.0, allow_nan=False), min_size=4, max_size=4),
    gain=st.floats(0.05, 2.0),
    max_rate=st.floats(0.01, 1.0),
    max_yaw=st.floats(0.01, 1.0),
)
def test_waypoint_saturation_is_uniform_and_within_limits(model, err, gain, max_rate, max_yaw) -> None:  # noqa: ANN001
    err = np.array(err)
    err[3] = (err[3] + np.pi) % (2 * np.pi) - np.pi  # the task wraps yaw errors
    xdot = waypoint_reference(model, err, gain, max_rate, max_yaw)
    raw = gain * err
    assert np.max(np.abs(xdot[:3])) <= max_rate + 1e-12 and abs(xdot[3]) <= max_yaw + 1e-12
    i = int(np.argmax(np.abs(raw)))
    scale = xdot[i] / raw[i] if raw[i] != 0 else 1.0
    np.testing.assert_allclose(xdot, scale * raw, rtol=1e-9, atol=1e-15)  # same direction: one factor for all four
    assert 0.0 < scale <= 1.0 + 1e-12
    if np.max(np.abs(raw[:3])) <= max_rate and abs(raw[3]) <= max_yaw:
        np.testing.assert_allclose(xdot, raw)  # within the limits: untouched
