"""UvmsController: smooth action switches, closed-loop grasp convergence,
compensation of vehicle drift, faults, stop, TPIK 2 reduction, telemetry.

Closed loops integrate in the test with perfect joint velocity tracking: the
arm at 100 Hz, the vehicle reference updated at 10 Hz; the vehicle follows its
reference plus, where stated, a drift the controller does not know about (but
which the velocity measurement sees, like a DVL would).
"""

from __future__ import annotations

import json
from dataclasses import replace

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from kcl import rotations
from kcl.actions import load_actions
from kcl.controller import ControllerConfig, MeasuredState, UvmsController
from kcl.model import UvmsModel
from kcl.rotations import integrate_pose, so3_log
from kcl.tasks import Targets, TaskContext

DT = 0.01  # s, arm rate 100 Hz
VEHICLE_EVERY = 10  # vehicle rate 10 Hz
FLOOR = 11.3  # m, depth of a flat bottom


@pytest.fixture(scope="module")
def model() -> UvmsModel:
    return UvmsModel.load()


@pytest.fixture(scope="module")
def actions(model):
    return load_actions(model=model)


def simulate(ctrl, model, q, eta, steps, t0=0.0, drift=None, record=None):
    """Integrate the closed loop; returns final (q, eta, t) and per-step data."""
    v_cmd = np.zeros(6)
    v_true = np.zeros(6)
    t = t0
    log = {"q": [], "qdot": [], "v": [], "mu": [], "tool": []}
    for k in range(steps):
        meas = MeasuredState(q, eta, v_true.copy(), t, altitude=FLOOR - eta[2])
        if k % VEHICLE_EVERY == 0:
            v_cmd = ctrl.vehicle_step(meas, t)
        qdot = ctrl.arm_step(meas, t)
        v_true = v_cmd + (drift(t) if drift is not None else 0.0)
        q = q + qdot * DT
        eta = integrate_pose(eta, v_true, DT)
        t += DT
        log["q"].append(q)
        log["qdot"].append(qdot)
        log["v"].append(v_cmd)
        if record:
            log["mu"].append(model.manipulability(q)[0])
            log["tool"].append(model.frame_pose_world(q, eta, "tool"))
    return q, eta, t, {k: np.array(v) for k, v in log.items()}


def reachable_goal(model, actions, rng, eta):
    """A reachable tool goal: the tool pose of a random configuration near the
    grasp posture (vehicle slightly moved, level) at which every inequality task
    of `grasp` is satisfied with zero activation (strictly feasible)."""
    for _ in range(200):
        q_goal = np.array(actions.postures["grasp_ready"]) + rng.uniform(-0.3, 0.3, model.n_joints)
        eta_goal = eta + np.r_[rng.uniform(-0.3, 0.3, 3), 0.0, 0.0, rng.uniform(-0.3, 0.3)]
        eta_goal[3:5] = 0.0
        goal = model.frame_pose_world(q_goal, eta_goal, "tool")
        ctx = TaskContext(model.kinematics(q_goal, eta_goal), Targets(tool_goal=goal), FLOOR - eta_goal[2])
        if all(
            not actions.tasks[n].evaluate(ctx).a.any()
            for n in actions.tasks_of("grasp")
            if actions.tasks[n].KIND == "inequality"
        ):
            return goal
    raise AssertionError("no feasible goal found")


def tool_error(model, q, eta, goal):
    T = model.frame_pose_world(q, eta, "tool")
    return float(np.linalg.norm(T[:3, 3] - goal[:3, 3])), float(np.linalg.norm(so3_log(goal[:3, :3] @ T[:3, :3].T)))


@pytest.mark.parametrize("seed", [1, 2, 3])
def test_grasp_converges_within_limits(model, actions, seed) -> None:
    rng = np.random.default_rng(seed)
    eta = np.array([0.0, 0.0, 10.0, 0.0, 0.0, rng.uniform(-3, 3)])
    start = "survey_folded" if seed == 1 else "grasp_ready"
    q = np.array(actions.postures[start]) + rng.uniform(-0.3, 0.3, model.n_joints)
    goal = reachable_goal(model, actions, rng, eta)
    ctrl = UvmsController(model, actions, ControllerConfig())
    ctrl.set_targets(tool_goal=goal)
    ctrl.set_action("grasp", 0.0)
    q, eta, t, log = simulate(ctrl, model, q, eta, 1600, record=True)
    pos_err, ang_err = tool_error(model, q, eta, goal)
    assert pos_err < 0.01 and ang_err < 0.02
    assert ctrl.convergence() < 0.02
    assert np.all(log["q"] >= model.joint_lower) and np.all(log["q"] <= model.joint_upper)
    mu_min = actions.tasks["manipulability"].params["mu_min"]
    assert np.min(log["mu"][50:]) > mu_min  # after the initial fade-in
    assert np.all(np.abs(log["qdot"]) <= model.joint_velocity_limit + 1e-9)
    assert np.all(np.abs(log["v"]) <= np.array(ctrl.config.vehicle_velocity_limit) + 1e-9)


def _drift(t: float) -> np.ndarray:
    """Zero-mean vehicle drift (m/s, rad/s): thrusters badly tracking near zero speed."""
    return np.array(
        [
            0.03 * np.sin(0.6 * t),
            0.03 * np.sin(0.45 * t + 1.0),
            0.015 * np.sin(0.9 * t),
            0.0,
            0.0,
            0.02 * np.sin(0.5 * t),
        ]
    )


def test_compensation_rejects_vehicle_drift(model, actions) -> None:
    rng = np.random.default_rng(7)
    eta0 = np.array([0.0, 0.0, 10.0, 0.0, 0.0, 0.3])
    q0 = np.array(actions.postures["grasp_ready"]) + rng.uniform(-0.2, 0.2, model.n_joints)
    goal = reachable_goal(model, actions, rng, eta0)
    errors = {}
    for comp in (True, False):
        ctrl = UvmsController(model, actions, ControllerConfig(compensation=comp))
        ctrl.set_targets(tool_goal=goal)
        ctrl.set_action("grasp", 0.0)
        q, eta, t, log = simulate(ctrl, model, q0.copy(), eta0.copy(), 1300, drift=_drift, record=True)
        errors[comp] = np.mean([np.linalg.norm(T[:3, 3] - goal[:3, 3]) for T in log["tool"][-300:]])
    assert errors[True] < 0.01
    assert errors[False] > 3 * errors[True]


def test_action_switch_is_smooth(model, actions) -> None:
    """Across grasp -> transport, references change by small steps only; the
    same switch with no transition time jumps (so the check can fail)."""
    rng = np.random.default_rng(11)
    eta0 = np.array([0.0, 0.0, 10.0, 0.0, 0.0, 0.0])
    q0 = np.array(actions.postures["grasp_ready"])
    goal = reachable_goal(model, actions, rng, eta0)

    def max_jump(acts):
        ctrl = UvmsController(model, acts, ControllerConfig())
        ctrl.set_targets(tool_goal=goal)
        ctrl.set_action("grasp", 0.0)
        q, eta, t, _ = simulate(ctrl, model, q0.copy(), eta0.copy(), 300)
        before = ctrl.arm_step(MeasuredState(q, eta, np.zeros(6), t, FLOOR - eta[2]), t)
        ctrl.set_action("transport", t)
        assert ctrl.current_action == "transport" and ctrl.previous_action == "grasp"
        _, _, _, log = simulate(ctrl, model, q, eta, 150, t0=t)
        qdots = np.vstack([before, log["qdot"]])
        return float(np.max(np.abs(np.diff(qdots, axis=0)))), ctrl

    smooth, ctrl = max_jump(actions)
    hard, _ = max_jump(replace(actions, transition_time=0.0))
    assert smooth < 0.03  # rad/s per 10 ms step
    assert hard > 2 * smooth
    assert ctrl.transition_progress(ctrl.state.t) == 1.0


def test_transport_posture_reached_and_convergence(model, actions) -> None:
    ctrl = UvmsController(model, actions, ControllerConfig())
    ctrl.set_action("transport", 0.0)
    eta = np.array([0.0, 0.0, 10.0, 0.0, 0.0, 0.0])
    q = np.array(actions.postures["grasp_ready"])
    q, eta, t, log = simulate(ctrl, model, q, eta, 1500)
    assert ctrl.convergence("transport") < 0.02
    np.testing.assert_allclose(q, actions.postures["transport"], atol=0.02)
    assert np.max(np.abs(log["v"][-100:])) < 1e-6  # vehicle_stop holds the vehicle
    assert ctrl.action_tasks("transport") == actions.tasks_of("transport")


def test_non_finite_input_faults_and_recovers(model, actions) -> None:
    ctrl = UvmsController(model, actions, ControllerConfig())
    ctrl.set_action("hold", 0.0)
    q = model.neutral()
    eta = np.array([0.0, 0.0, 10.0, 0.0, 0.0, 0.0])
    bad = [
        MeasuredState(np.r_[q[:-1], np.nan], eta, np.zeros(6), 1.0),
        MeasuredState(q, np.r_[eta[:5], np.inf], np.zeros(6), 1.0),
        MeasuredState(q, eta, np.array([0, 0, np.nan, 0, 0, 0.0]), 1.0),
        MeasuredState(q, eta, np.zeros(6), 1.0, altitude=float("nan")),
    ]
    for meas in bad:
        v = ctrl.vehicle_step(meas, 1.0)
        qd = ctrl.arm_step(meas, 1.0)
        assert np.all(v == 0) and np.all(qd == 0)
        tel = ctrl.telemetry()
        assert tel["fault"] and "non-finite" in tel["fault_reason"]
    ctrl.set_targets(tool_goal=np.full((4, 4), np.nan))
    ctrl.set_action("grasp", 1.0)
    assert np.all(ctrl.arm_step(MeasuredState(q, eta, np.zeros(6), 2.0), 2.0) == 0)
    assert "tool_goal" in ctrl.telemetry()["fault_reason"]
    ctrl.clear_targets()
    out = ctrl.arm_step(MeasuredState(q, eta, np.zeros(6), 2.1), 2.1)
    assert np.all(np.isfinite(out)) and not ctrl.telemetry()["fault"]
    with pytest.raises(ValueError):
        ctrl.arm_step(MeasuredState(q[:3], eta, None, 2.2), 2.2)


def test_stop_zeroes_until_next_action(model, actions) -> None:
    ctrl = UvmsController(model, actions, ControllerConfig())
    ctrl.set_action("transport", 0.0)
    eta = np.array([0.0, 0.0, 10.0, 0.0, 0.0, 0.0])
    q = np.array(actions.postures["grasp_ready"])
    q, eta, t, _ = simulate(ctrl, model, q, eta, 100)
    meas = MeasuredState(q, eta, np.zeros(6), t, 1.0)
    assert np.any(ctrl.arm_step(meas, t) != 0)
    ctrl.stop(t)
    for k in range(5):
        m = replace(meas, t=t + 0.01 * k)
        assert np.all(ctrl.arm_step(m, m.t) == 0) and np.all(ctrl.vehicle_step(m, m.t) == 0)
    assert ctrl.telemetry()["stopped"]
    ctrl.set_action("transport", t + 0.1)  # resumes, fading back in from zero
    first = ctrl.arm_step(replace(meas, t=t + 0.11), t + 0.11)
    later = ctrl.arm_step(replace(meas, t=t + 0.7), t + 0.7)
    assert np.max(np.abs(first)) < 0.2 * np.max(np.abs(later))


def test_underactuated_vehicle_and_compensation_off(model, actions) -> None:
    cfg = ControllerConfig(actuated_dofs=(True, True, True, False, False, True), compensation=False)
    ctrl = UvmsController(model, actions, cfg)
    eta = np.array([0.0, 0.0, 10.0, 0.05, -0.05, 0.0])
    q = np.array(actions.postures["grasp_ready"])
    rng = np.random.default_rng(3)
    ctrl.set_targets(tool_goal=reachable_goal(model, actions, rng, eta))
    ctrl.set_action("grasp", -1.0)
    meas = MeasuredState(q, eta, np.array([0, 0, 0, 0.02, -0.01, 0.0]), 0.0, 0.9)
    v = ctrl.vehicle_step(meas, 0.0)
    assert v[3] == 0.0 and v[4] == 0.0 and np.any(v != 0)
    ctrl.arm_step(meas, 0.0)
    # compensation off: TPIK 2 was fed the commanded vehicle velocity
    np.testing.assert_allclose(ctrl.state.v_tpik2, v)
    assert ctrl.telemetry()["compensation"] is False


def test_telemetry_is_json(model, actions) -> None:
    ctrl = UvmsController(model, actions, ControllerConfig())
    rng = np.random.default_rng(8)
    eta = np.array([0.0, 0.0, 10.0, 0.0, 0.0, 0.0])
    ctrl.set_targets(tool_goal=reachable_goal(model, actions, rng, eta))
    ctrl.set_action("survey", 0.0)
    ctrl.set_action("grasp", 0.2)
    meas = MeasuredState(np.array(actions.postures["survey_folded"]), eta, np.zeros(6), 0.4, 0.9)
    ctrl.step(meas, 0.4)
    tel = json.loads(json.dumps(ctrl.telemetry()))
    assert tel["action"] == "grasp" and tel["previous_action"] == "survey"
    assert tel["transition_progress"] == pytest.approx(0.4)
    assert set(actions.tasks_of("grasp")) <= set(tel["tasks"])
    jl = tel["tasks"]["joint_limits"]
    assert (
        len(jl["activation"]) == model.n_joints
        and len(jl["error"]) == model.n_joints
        and len(jl["reference"]) == model.n_joints
    )
    assert 0.0 < tel["tasks"]["tool_position"]["a_p"] < 1.0  # fading in
    assert tel["tasks"]["waypoint"]["note"] == "no vehicle_goal"
    with pytest.raises(KeyError):
        ctrl.set_action("grasping", 1.0)


def test_telemetry_rows_are_the_batch_rows_bit_for_bit(model, actions) -> None:
    """The per-task rows of the telemetry and its ``limited`` field are the batch's
    arrays as numpy computes them (activation times a_p, error, reference, the
    commanded rates J [qdot; v], the reference's share), bit for bit."""
    ctrl = UvmsController(model, actions, ControllerConfig())
    rng = np.random.default_rng(11)
    eta = np.array([0.0, 0.0, 10.0, 0.1, -0.05, 0.3])
    ctrl.set_targets(tool_goal=reachable_goal(model, actions, rng, eta))
    ctrl.set_action("survey", 0.0)
    ctrl.set_action("grasp", 0.2)
    q = np.array(actions.postures["survey_folded"]) + 0.05
    meas = MeasuredState(q, eta, np.array([0.05, 0.0, 0.02, 0.0, 0.0, 0.01]), 0.4, 0.9)
    ctrl.step(meas, 0.4)
    tel = ctrl.telemetry()
    batch = ctrl.batch
    rates = batch.J @ np.concatenate((ctrl.state.qdot_cmd, ctrl.state.v_cmd))
    seen = 0
    for name, row in tel["tasks"].items():
        k = batch.index[name]
        s = batch.slices[k]
        a_p = float(batch.ap_rec[k])
        activation = batch.A[s] * a_p if a_p < 1.0 else batch.A[s]
        assert row["activation"] == activation.tolist()
        assert row["error"] == batch.E[s].tolist() and row["reference"] == batch.XD[s].tolist()
        assert row["commanded_rate"] == rates[s].tolist()
        seen += 0.0 < a_p < 1.0
    assert seen  # tasks fading in: the a_p product was exercised
    assert tel["limited"]  # the fading goals move slower than their references
    for name, entry in tel["limited"].items():
        s = batch.slices[batch.index[name]]
        ref = batch.XD[s]
        norm = float(np.linalg.norm(ref))
        assert entry["ratio"] == float(np.dot(rates[s], ref)) / (norm * norm)
        assert all(batch.A[batch.slices[batch.index[above]]].any() for above in entry["by"])


def test_switch_during_transition_keeps_a_p_continuous(model, actions) -> None:
    """A new switch in the middle of a fade starts every task from its current a_p."""
    ctrl = UvmsController(model, actions, ControllerConfig())
    ctrl.set_action("grasp", 0.0)
    ctrl.set_action("transport", 1.0)
    t = 1.2  # transport fading in, grasp-only tasks fading out
    before = {n: ctrl.blend.factor(n, t) for n in ctrl.blend.names}
    assert 0.0 < before["tool_position"] < 1.0 and 0.0 < before["transport_posture"] < 1.0
    ctrl.set_action("hold", t)
    after = {n: ctrl.blend.factor(n, t) for n in ctrl.blend.names}
    assert after == pytest.approx(before)
    T = actions.transition_time
    end = {n: ctrl.blend.factor(n, t + T) for n in ctrl.blend.names}
    assert end == {n: (1.0 if n in actions.tasks_of("hold") else 0.0) for n in ctrl.blend.names}
    # a_p never jumps along the way
    ts = np.linspace(t, t + T, 51)
    for name in ("tool_position", "transport_posture", "arm_stop", "joint_limits"):
        values = np.array([ctrl.blend.factor(name, s) for s in ts])
        assert np.max(np.abs(np.diff(values))) < 0.1


def test_survey_reaches_waypoint_folds_arm_and_keeps_altitude(model, actions) -> None:
    """Survey: the vehicle goes to its waypoint with the arm folding; a waypoint
    below the minimum altitude is not followed down (the safety task wins)."""
    ctrl = UvmsController(model, actions, ControllerConfig())
    eta = np.array([0.0, 0.0, 9.5, 0.0, 0.0, 0.0])  # 1.8 m above the bottom
    q = np.array(actions.postures["grasp_ready"])
    ctrl.set_targets(vehicle_goal=np.array([1.0, -0.5, 9.8, 0.3]))
    ctrl.set_action("survey", 0.0)
    q, eta, t, log = simulate(ctrl, model, q, eta, 1200)
    np.testing.assert_allclose(eta[[0, 1, 2, 5]], [1.0, -0.5, 9.8, 0.3], atol=0.03)
    np.testing.assert_allclose(q, actions.postures["survey_folded"], atol=0.05)
    assert ctrl.convergence() < 0.1  # largest of the waypoint and fold-posture error norms
    # a waypoint 0.3 m above the bottom: altitude stays above its minimum
    min_alt = actions.tasks["altitude"].params["min_altitude"]
    ctrl.set_targets(vehicle_goal=np.array([1.0, -0.5, FLOOR - 0.3, 0.3]))
    altitudes = []
    for _ in range(8):
        q, eta, t, _ = simulate(ctrl, model, q, eta, 100, t0=t)
        altitudes.append(FLOOR - eta[2])
    assert min(altitudes) > min_alt
    assert altitudes[-1] < min_alt + actions.tasks["altitude"].params["width"]  # it did go down to the band


def test_underactuated_vehicle_grasps_while_rolling(model, actions) -> None:
    """Roll and pitch not actuated (BlueROV2-like) and oscillating on their own:
    the measured-velocity task keeps TPIK 1 off them, the arm compensates."""
    rng = np.random.default_rng(2)
    eta = np.array([0.0, 0.0, 10.0, 0.0, 0.0, 0.7])
    q = np.array(actions.postures["grasp_ready"]) + rng.uniform(-0.3, 0.3, model.n_joints)
    goal = reachable_goal(model, actions, rng, eta)
    ctrl = UvmsController(model, actions, ControllerConfig(actuated_dofs=(True, True, True, False, False, True)))
    ctrl.set_targets(tool_goal=goal)
    ctrl.set_action("grasp", 0.0)

    def sway(t):
        return np.array([0.0, 0.0, 0.0, 0.02 * np.sin(1.3 * t), 0.02 * np.cos(0.9 * t), 0.0])

    q, eta, t, log = simulate(ctrl, model, q, eta, 1400, drift=sway)
    pos_err, ang_err = tool_error(model, q, eta, goal)
    assert pos_err < 0.005 and ang_err < 0.01
    assert not log["v"][:, 3:5].any()  # never commands the non-actuated DOFs


_floats = st.floats(-1.0, 1.0, allow_nan=False)


@settings(max_examples=60, deadline=None)
@given(
    st.lists(_floats, min_size=7, max_size=7),
    st.lists(_floats, min_size=6, max_size=6),
    st.lists(_floats, min_size=6, max_size=6),
    st.lists(_floats, min_size=6, max_size=6),
    st.sampled_from(["survey", "grasp", "transport", "hold"]),
    st.floats(0.0, 2.0),
)
def test_outputs_always_finite_and_within_limits(q_u, eta_u, v_u, goal_u, action, t) -> None:
    """Any finite state, target and action time: finite references within limits."""
    model, actions = _shared()
    q = model.neutral() + np.array(q_u) * 0.5 * (model.joint_upper - model.joint_lower)  # may exceed the limits
    eta = np.array([5 * eta_u[0], 5 * eta_u[1], 10 + eta_u[2], 0.5 * eta_u[3], 0.5 * eta_u[4], 3 * eta_u[5]])
    goal = np.eye(4)
    goal[:3, :3] = rotations.rpy_to_matrix(*(3 * np.array(goal_u[3:])))
    goal[:3, 3] = eta[:3] + 2 * np.array(goal_u[:3])
    ctrl = UvmsController(model, actions, ControllerConfig())
    ctrl.set_targets(tool_goal=goal, vehicle_goal=np.r_[goal[:3, 3], goal_u[5]], camera_target=goal[:3, 3] + 0.1)
    ctrl.set_action(action, 0.0)
    meas = MeasuredState(q, eta, 0.2 * np.array(v_u), t, altitude=FLOOR - eta[2])
    v, qdot = ctrl.step(meas, t)
    assert np.all(np.isfinite(v)) and np.all(np.isfinite(qdot))
    assert np.all(np.abs(v) <= np.array(ctrl.config.vehicle_velocity_limit) + 1e-12)
    assert np.all(np.abs(qdot) <= model.joint_velocity_limit + 1e-12)
    assert not ctrl.telemetry()["fault"]


_SHARED: dict = {}


def _shared():
    if not _SHARED:
        model = UvmsModel.load()
        _SHARED["v"] = (model, load_actions(model=model))
    return _SHARED["v"]


def test_a_jog_into_a_joint_limit_stops_there_and_names_it(model, actions) -> None:
    """The operator turns the tool about its own axis for 30 s (6 rad at 0.2
    rad/s) with the vehicle held (zero vehicle limits): the arm rolls into its
    joint limit bands, never past the limits; the telemetry says the jog is
    limited, by the joint limits."""
    ctrl = UvmsController(model, actions, ControllerConfig(vehicle_velocity_limit=(0.0,) * 6))
    eta = np.array([0.0, 0.0, 8.0, 0.0, 0.0, 0.0])  # 3.3 m above the bottom: the tool well clear of it
    q = np.array(actions.postures["grasp_ready"])
    axis = model.frame_pose_world(q, eta, "tool")[:3, 2]  # the tool's z axis, world
    ctrl.set_targets(tool_velocity=np.r_[0.0, 0.0, 0.0, 0.2 * axis])
    ctrl.set_action("jog_tool", 0.0)
    q, eta, t, log = simulate(ctrl, model, q, eta, 3000)
    margin = actions.tasks["joint_limits"].params["margin"]
    assert np.all(log["q"] >= model.joint_lower + margin - 1e-3)
    assert np.all(log["q"] <= model.joint_upper - margin + 1e-3)
    assert np.abs(log["qdot"][100]).max() > 0.1  # it did turn at first
    limit = ctrl.telemetry()["limited"]["tool_jog"]
    assert limit["ratio"] < 0.9 and "joint_limits" in limit["by"]


def test_a_vehicle_jog_against_the_geofence_stops_inside(model, actions) -> None:
    """The operator drives the vehicle north into the geofence: it slows down and
    stops within the fence (the margin kept), the telemetry names the geofence."""
    ctrl = UvmsController(model, actions, ControllerConfig())
    eta = np.array([20.0, 6.0, 2.0, 0.0, 0.0, 0.0])
    q = np.array(actions.postures["survey_folded"])
    fence = np.array([[0.0, 25.0], [0.0, 12.0], [0.0, 4.0]])
    ctrl.set_targets(vehicle_velocity=np.array([0.3, 0.0, 0.0, 0.0, 0.0, 0.0]), geofence=fence)
    ctrl.set_action("jog_vehicle", 0.0)
    q, eta, t, log = simulate(ctrl, model, q, eta, 4000)
    margin = actions.tasks["geofence"].params["margin"]
    assert eta[0] <= 25.0 - margin + 0.05
    assert eta[0] > 23.0  # it did go most of the way
    assert "geofence" in ctrl.telemetry()["limited"]["vehicle_jog"]["by"]
    assert np.abs(log["q"] - log["q"][0]).max() < 1e-3  # the arm held still


def test_a_tool_jog_down_into_the_bottom_stops_above_it_and_names_it(model, actions) -> None:
    """The operator pushes the tool straight down for 40 s (4 m at 0.1 m/s) over a flat
    bottom 3 m below the vehicle: arm and vehicle take it down until the clearance task's
    band, never below its minimum; the vehicle stays above its altitude floor; the
    telemetry names the tool clearance (or the vehicle's altitude) as what held it back."""
    ctrl = UvmsController(model, actions, ControllerConfig())
    eta = np.array([0.0, 0.0, FLOOR - 3.0, 0.0, 0.0, 0.0])
    q = np.array(actions.postures["grasp_ready"])
    ctrl.set_targets(tool_velocity=np.array([0.0, 0.0, 0.1, 0.0, 0.0, 0.0]))
    ctrl.set_action("jog_tool", 0.0)
    q, eta, t, log = simulate(ctrl, model, q, eta, 4000, record=True)
    lowest = max(T[2, 3] for T in log["tool"])  # deepest tool position (NED: z down)
    clearance = actions.tasks["tool_clearance"].params["min_clearance"]
    assert FLOOR - lowest >= clearance - 0.01
    assert FLOOR - lowest < clearance + 0.15  # it did go down to the band
    assert FLOOR - eta[2] >= actions.tasks["altitude"].params["min_altitude"] - 0.01
    by = ctrl.telemetry()["limited"]["tool_jog"]["by"]
    assert "tool_clearance" in by or "altitude" in by
