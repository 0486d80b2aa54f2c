"""The shipped MARIS mission on the simulator with the real KCL controller:
survey until the pipe is seen (grasp pose stored in world NED), the halt
contract when the tree is interrupted, the abort path (hold still, fold the
arm, surface), and the whole mission. The multi-rate loop of the test context
(tests/behaviours/conftest.py) stands in for the supervisor's."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from py_trees.common import Status

from behaviours.context import MissionBlackboard
from mission.compiler import compile_abort, compile_mission
from mission.loader import load_mission

MISSIONS = Path(__file__).resolve().parents[2] / "missions"
MISSION = MISSIONS / "maris_pipe_recovery.yaml"


def kcl_ctx(make_kcl_ctx, mission, seed: int = 3):
    """Real controller + simulator context with the mission's blackboard and rates."""
    assert mission.model is None and mission.actions_file is None  # shipped missions use the defaults
    r = mission.rates
    ctx = make_kcl_ctx(seed=seed, tree_hz=r.tree_hz, vehicle_hz=r.vehicle_hz, arm_hz=r.arm_hz)
    ctx.blackboard = MissionBlackboard.for_mission(mission)
    return ctx


@pytest.fixture(scope="module")
def mission():
    return load_mission(MISSION)


@pytest.mark.parametrize("name", ["maris_pipe_recovery.yaml", "pipe_recovery_guarded.yaml"])
def test_survey_finds_the_pipe_then_halt_stops_everything(name, make_kcl_ctx):
    mission = load_mission(MISSIONS / name)
    ctx = kcl_ctx(make_kcl_ctx, mission)
    root = compile_mission(mission, ctx)
    status = ctx.run(root, max_s=60, until=lambda: ctx.controller.current_action == "grasp")
    assert status == Status.RUNNING and ctx.controller.current_action == "grasp"
    kinds = ctx.events.kinds()
    assert kinds.index("action_success") < kinds.index("gripper_command")  # fold, then survey succeeded
    pose = ctx.blackboard.get("grasp_pose")
    truth = ctx.sim.pipe_grasp_pose()
    assert np.linalg.norm(pose[:3, 3] - truth[:3, 3]) < 0.25  # vision noise and latency while moving
    # interrupt the running tree: the halt contract zeroes every motion command at once
    root.stop(Status.INVALID)
    gt = ctx.sim.ground_truth()
    assert ctx.controller.stopped
    assert gt["vehicle"]["commanded_velocity"] == [0.0] * 6
    assert ctx.events.kinds()[-1] == "halted"


def test_abort_path_holds_folds_and_surfaces(mission, make_kcl_ctx):
    ctx = kcl_ctx(make_kcl_ctx, mission, seed=5)
    abort = compile_abort(mission, ctx)
    assert ctx.run(abort, max_s=120) == Status.SUCCESS, abort.tip().feedback_message
    nav = ctx.devices.vehicle.navigation()
    assert nav.depth <= 0.3 + 0.3
    assert [e["node"] for e in ctx.events.events if e["kind"] == "action_success"] == [
        "Hold still",
        "Fold the arm",
        "Surface",
    ]


@pytest.mark.slow
def test_maris_mission_grasps_the_pipe_end_to_end(mission, make_kcl_ctx):
    """Survey, grasp confirmed by the hand currents, transport posture: the
    whole MARIS mission on the simulator (one seed; campaigns measure rates)."""
    ctx = kcl_ctx(make_kcl_ctx, mission, seed=3)
    root = compile_mission(mission, ctx)
    assert ctx.run(root, max_s=200) == Status.SUCCESS, root.tip().feedback_message
    assert ctx.sim.ground_truth()["grasp"] == "holding"
    done = [e["node"] for e in ctx.events.events if e["kind"] == "action_success"]
    assert done[:3] == ["Fold the arm", "Survey until the pipe is seen", "Reach the grasp frame"]
    assert done[-1] == "Transport posture"
    assert ctx.blackboard.get("grasp_attempts") >= 1
