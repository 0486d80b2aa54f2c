"""Actions file: the default loads, mistakes are reported with file:line:column."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from kcl.actions import DEFAULT_ACTIONS, load_actions, parse_actions
from kcl.model import UvmsModel
from maris_common.yamlsrc import ConfigError


@pytest.fixture(scope="module")
def model() -> UvmsModel:
    return UvmsModel.load()


@pytest.fixture(scope="module")
def default_text() -> str:
    return DEFAULT_ACTIONS.read_text()


def line_of(text: str, needle: str) -> int:
    return next(i for i, line in enumerate(text.splitlines(), 1) if needle in line)


def test_default_actions_load(model: UvmsModel) -> None:
    acts = load_actions(model=model)
    assert {"survey", "grasp", "transport", "hold"} <= set(acts.actions)
    # the MARIS grasp action: seven tasks in this order, under the safety tasks
    grasp_types = [acts.tasks[n].TYPE for n in acts.tasks_of("grasp")]
    assert grasp_types[-7:] == [
        "arm_joint_limits",
        "arm_manipulability",
        "elbow_camera_occlusion",
        "camera_centering",
        "tool_position",
        "tool_orientation",
        "arm_preferred_shape",
    ]
    assert grasp_types[:3] == ["vehicle_geofence", "vehicle_altitude", "vehicle_horizontal_attitude"]
    assert acts.transition_time == pytest.approx(0.5)
    # actions are subsets of one hierarchy, listed in its priority order
    for name, tasks in acts.actions.items():
        levels = [acts.level_of[t] for t in tasks]
        assert levels == sorted(levels), name
    for posture in acts.postures.values():
        q = np.array(posture, dtype=float)
        assert np.all(q > model.joint_lower) and np.all(q < model.joint_upper)


def test_wrong_task_name_reports_its_line(model: UvmsModel, default_text: str, tmp_path: Path) -> None:
    text = default_text.replace("vehicle_stop, arm_stop]", "vehicle_stop, arm_stpo]")
    copy = tmp_path / "actions.yaml"
    copy.write_text(text)
    with pytest.raises(ConfigError) as err:
        load_actions(copy, model)
    msg = str(err.value)
    assert f"{copy}:{line_of(text, 'arm_stpo]')}:" in msg
    assert "actions.hold[5]" in msg and "unknown task `arm_stpo`" in msg and "did you mean `arm_stop`" in msg


def test_all_problems_reported_at_once(model: UvmsModel, default_text: str) -> None:
    text = (
        default_text.replace("type: camera_centering", "type: camera_centring")
        .replace("mu_min: 0.02", "mu_min: -0.02")
        .replace("max_yaw_rate: 0.15", "max_yaw_rat: 0.15")
        .replace("posture: transport\n", "posture: transprt\n")
    )
    with pytest.raises(ConfigError) as err:
        parse_actions(text, model, file="a.yaml")
    issues = err.value.issues
    msgs = [str(i) for i in issues]
    assert len(issues) == 4, msgs
    assert any("type: unknown task type 'camera_centring'" in m and "camera_centering" in m for m in msgs)
    assert any(f"a.yaml:{line_of(text, 'mu_min: -0.02')}:" in m and "mu_min: must be > 0" in m for m in msgs)
    assert any("unknown key `max_yaw_rat`" in m and "did you mean `max_yaw_rate`" in m for m in msgs)
    assert any("unknown posture `transprt`" in m for m in msgs)


@pytest.mark.parametrize(
    "snippet, expected",
    [
        ("hierarchy: []\nactions: {a: [x]}", "non-empty list of priority levels"),
        ("hierarchy:\n  - {name: j, type: arm_joint_limits, gain: yes}\nactions: {a: [j]}", "expected a number"),
        (
            "hierarchy:\n  - {name: j, type: arm_joint_limits}\n  - {name: j, type: arm_velocity_minimization}\nactions: {a: [j]}",
            "duplicate task name",
        ),
        (
            "hierarchy:\n  - {name: s, type: arm_preferred_shape, posture: [0, 1]}\nactions: {a: [s]}",
            "expected 7 entries",
        ),
        ("hierarchy:\n  - {name: s, type: arm_preferred_shape}\nactions: {a: [s]}", "needs `posture`"),
        ("hierarchy:\n  - {name: p, type: tool_position, frame: wrist}\nactions: {a: [p]}", "unknown frame"),
        ("hierarchy:\n  - {name: j, type: arm_joint_limits}\nactions: {a: [j, j]}", "listed twice"),
        ("hierarchy:\n  - {name: j, type: arm_joint_limits}\nactions: {a: [j]}\nextra: 1", "unknown key `extra`"),
        ("hierarchy:\n  - {name: j, type: arm_joint_limits, width: 2.0}\nactions: {a: [j]}", "no free range"),
        ("!!python/object:os.system {}", "unsupported YAML"),
    ],
)
def test_bad_files(model: UvmsModel, snippet: str, expected: str) -> None:
    with pytest.raises(ConfigError) as err:
        parse_actions(snippet, model, file="bad.yaml")
    assert expected in str(err.value)
    assert "bad.yaml:" in str(err.value)


def test_shared_level_and_level_settings(model: UvmsModel) -> None:
    text = """
hierarchy:
  - level:
      - {name: pos, type: tool_position}
      - {name: ori, type: tool_orientation}
    lam: 1.0e-3
  - {name: stop, type: arm_velocity_minimization, threshold: 0.05}
actions:
  reach: [ori, pos, stop]
"""
    acts = parse_actions(text, model)
    assert len(acts.levels) == 2
    assert [t.name for t in acts.levels[0].tasks] == ["pos", "ori"]
    assert acts.levels[0].lam == pytest.approx(1e-3) and acts.levels[1].threshold == pytest.approx(0.05)
    assert acts.tasks_of("reach") == ("pos", "ori", "stop")  # priority order, not file order
    with pytest.raises(KeyError, match="did you mean `reach`"):
        acts.tasks_of("rech")


def test_goal_flag(model: UvmsModel) -> None:
    acts = load_actions(model=model)
    assert acts.tasks["tool_position"].is_goal and acts.tasks["transport_posture"].is_goal
    assert not acts.tasks["grasp_shape"].is_goal  # `goal: false` in the file
    assert not acts.tasks["joint_limits"].is_goal  # inequalities never count
