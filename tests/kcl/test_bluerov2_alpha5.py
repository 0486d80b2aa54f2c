"""The Reach Alpha 5 on a BlueROV2 Heavy: what its KCL actions keep and give up.

A four-joint arm cannot hold the tool's position and its whole orientation on its
own (3 + 3 > 4), nor point its jaw straight down (a vertical forearm puts the wrist
rotation on the base rotation's axis: a singularity the manipulability task keeps
away). kcl/data/bluerov2_alpha5_actions.yaml orders the tasks so that this degrades
as designed: safety first, the tool position, the jaw's axis along the pipe, the
whole orientation last. These tests measure it on the controller, closed
kinematically (the commanded velocities applied exactly).
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from kcl.actions import load_actions, parse_actions
from kcl.controller import ControllerConfig, MeasuredState, UvmsController
from kcl.model import DATA_DIR, UvmsModel
from kcl.rotations import integrate_pose, rpy_to_matrix, so3_log

URDF = DATA_DIR / "bluerov2_heavy_alpha5.urdf"
ACTIONS = DATA_DIR / "bluerov2_alpha5_actions.yaml"
FLOOR = 3.0  # m, pool depth (flat floor) for the altitude task
ARDUSUB_DOFS = (True, True, True, False, False, True)  # what the KCL commands on this vehicle


@pytest.fixture(scope="module")
def model() -> UvmsModel:
    return UvmsModel.load(URDF)


def run(
    model: UvmsModel,
    actions_path_or_text: Path | str,
    action: str,
    goal: np.ndarray,
    q0: np.ndarray,
    eta0: np.ndarray,
    *,
    vehicle_moves: bool,
    seconds: float = 20.0,
) -> tuple[np.ndarray, np.ndarray, list[float]]:
    """Run ``action`` towards the tool ``goal`` (4x4 world) for ``seconds``: arm at 100 Hz,
    vehicle at 10 Hz (or held still when ``vehicle_moves`` is False: no actuated DOF).
    Returns the final joints, pose and the manipulability seen at every arm step."""
    if isinstance(actions_path_or_text, Path):
        actions = load_actions(actions_path_or_text, model)
    else:
        actions = parse_actions(actions_path_or_text, model)
    dofs = ARDUSUB_DOFS if vehicle_moves else (False,) * 6
    ctl = UvmsController(model, actions, ControllerConfig(vehicle_rate_hz=10, arm_rate_hz=100, actuated_dofs=dofs))
    ctl.set_action(action, 0.0)
    ctl.set_targets(tool_goal=goal)
    q, eta, v = q0.astype(float).copy(), eta0.astype(float).copy(), np.zeros(6)
    mus = []
    dt = 0.01
    for k in range(int(seconds / dt)):
        t = k * dt
        meas = MeasuredState(q.copy(), eta.copy(), v.copy(), t, FLOOR - eta[2])
        if k % 10 == 0:
            v, qdot = ctl.step(meas, t)
        else:
            qdot = ctl.arm_step(meas, t)
        q = q + qdot * dt
        eta = integrate_pose(eta, v, dt)
        mus.append(model.kinematics(q, eta).manipulability("tool")[0])
    return q, eta, mus


def errors(model: UvmsModel, q: np.ndarray, eta: np.ndarray, goal: np.ndarray) -> tuple[float, float, float]:
    """(position m, angle between the tool's x and the goal's x as lines rad, whole orientation rad)."""
    tool = model.kinematics(q, eta).pose_world("tool")
    pos = float(np.linalg.norm(tool[:3, 3] - goal[:3, 3]))
    axis = math.acos(min(1.0, abs(float(tool[:3, 0] @ goal[:3, 0]))))
    whole = float(np.linalg.norm(so3_log(goal[:3, :3] @ tool[:3, :3].T)))
    return pos, axis, whole


def grasp_goal(model: UvmsModel, eta: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """A grasp frame the arm alone can reach in position and axis but not in whole
    orientation, and the grasp-ready posture to start from. The frame is the tool's
    at a posture near grasp-ready (so its position and its x are reachable) turned
    about that x until its z points straight down, as a pipe's grasp frame does: the
    jaw would have to approach vertically, which the Alpha cannot (a singularity)."""
    acts = load_actions(ACTIONS, model)
    q_ready = np.array(acts.postures["grasp_ready"], dtype=float)
    there = model.kinematics(q_ready + np.array([0.15, 0.1, -0.1, 0.2]), eta).pose_world("tool")
    x = there[:3, 0]
    down = np.array([0.0, 0.0, 1.0])
    z = down - (down @ x) * x
    z /= np.linalg.norm(z)
    goal = there.copy()
    goal[:3, :3] = np.column_stack([x, np.cross(z, x), z])
    return goal, q_ready


def test_reach_keeps_position_and_axis_and_gives_up_the_unreachable_orientation(model: UvmsModel) -> None:
    """Vehicle held still (only the arm's four joints): the position (3) and the jaw's
    axis (1) take all of them; the whole orientation (a straight-down approach the
    arm cannot take) is not held, and the safety tasks are met all along."""
    eta0 = np.array([5.0, 4.0, 2.5, 0.0, 0.0, 0.3])
    goal, q_ready = grasp_goal(model, eta0)
    q, eta, mus = run(model, ACTIONS, "reach", goal, q_ready, eta0, vehicle_moves=False)
    pos, axis, whole = errors(model, q, eta, goal)
    assert pos < 0.002, pos
    assert axis < 0.01, axis
    assert whole > 0.3, whole  # the approach stays tilted: given up
    np.testing.assert_allclose(eta, eta0)  # the vehicle did not move
    assert np.all(q >= model.joint_lower) and np.all(q <= model.joint_upper)
    assert min(mus) > 0.025  # manipulability (mu_min 0.03, a bell over 0.03 wide) kept


def test_the_priority_decides_what_is_given_up(model: UvmsModel) -> None:
    """The same arm with the whole orientation above the position (the hierarchy
    swapped): now the position is what is given up. The order of the actions file
    is what keeps the tool on the pipe."""
    text = ACTIONS.read_text()
    start, end = text.index("  - name: tool_position"), text.index("  - name: tool_axis")
    orient_start = text.index("  - name: tool_orientation")
    orient_end = text.index("  - name: grasp_shape")
    swapped = (
        text[:start] + text[orient_start:orient_end] + text[start:end] + text[end:orient_start] + text[orient_end:]
    )
    eta0 = np.array([5.0, 4.0, 2.5, 0.0, 0.0, 0.3])
    goal, q_ready = grasp_goal(model, eta0)
    q, eta, _ = run(model, swapped, "reach", goal, q_ready, eta0, vehicle_moves=False)
    pos, _, _ = errors(model, q, eta, goal)
    assert pos > 0.01, pos


def test_grasp_with_the_vehicle_converges_and_keeps_the_safety_tasks(model: UvmsModel) -> None:
    """The shipped grasp action with the vehicle moving (x, y, z, yaw) from a start
    0.3 m off: the tool reaches the grasp frame with its jaw along the pipe, the
    joints stay in their limits, the vehicle level and above its altitude floor."""
    eta0 = np.array([5.0, 4.0, 2.5, 0.0, 0.0, 0.3])
    goal, q_ready = grasp_goal(model, eta0)
    goal[:3, 3] += rpy_to_matrix(0.0, 0.0, eta0[5]) @ np.array([0.25, -0.15, 0.1])  # out of the arm's reach
    q, eta, mus = run(model, ACTIONS, "grasp", goal, q_ready, eta0, vehicle_moves=True, seconds=30.0)
    pos, axis, _ = errors(model, q, eta, goal)
    assert pos < 0.003 and axis < 0.02, (pos, axis)
    assert np.all(q >= model.joint_lower) and np.all(q <= model.joint_upper)
    assert abs(eta[3]) < 1e-12 and abs(eta[4]) < 1e-12  # roll, pitch: not the KCL's
    assert FLOOR - eta[2] > 0.3
    assert min(mus) > 0.025
