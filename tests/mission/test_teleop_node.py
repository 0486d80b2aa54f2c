"""The ``teleop`` node: its fields read with file:line errors, all at once; the
capability check (the operator inputs the HAL config has, what they can send, the
actions the modes run); the bounded-leaf lint; the JSON Schema takes it; it compiles
to the teleop leaf."""

from __future__ import annotations

import textwrap
from pathlib import Path

import jsonschema
import pytest
import yaml

from behaviours.teleop import Teleop
from maris_common.yamlsrc import ConfigError
from mission.compiler import compile_mission
from mission.jsonschema import mission_schema
from mission.loader import load_mission, load_mission_text

ROOT = Path(__file__).resolve().parents[2]
SIM = ROOT / "hal" / "configs" / "sim.yaml"
FIELD = ROOT / "hal" / "configs" / "bluerov2_canopen_arm.yaml"  # no operator input

HEADER = """\
name: t
safety:
  max_depth_m: 4
  min_altitude_m: 0.5
  max_duration_s: 600
  geofence: {north_m: [0, 25], east_m: [0, 12], down_m: [0, 4]}
abort:
  action: {run: hold, timeout_s: 5}
"""


def text(body: str) -> str:
    return HEADER + textwrap.dedent(body)


def issues(body: str, hal=None) -> list[str]:
    with pytest.raises(ConfigError) as exc:
        load_mission_text(text(body), "m.yaml", hal)
    return [str(i) for i in exc.value.issues]


def line_of(body: str, needle: str) -> int:
    return next(i for i, line in enumerate(text(body).splitlines(), 1) if needle in line)


def test_a_teleop_node_reads_with_its_defaults():
    m = load_mission_text(text("tree:\n  teleop: {timeout_s: 120}\n"), "m.yaml")
    p = m.tree.params
    assert p["modes"] == ("tool_velocity", "vehicle_velocity", "vehicle_goal", "tool_goal", "point_at")
    assert p["frame"] == "vehicle" and p["deadman_s"] == 0.5 and p["goal_max_age_s"] == 10.0
    assert p["handback"] == {"button": True, "service": True, "until": None}
    assert m.tree.name.startswith("Operator control")


def test_every_problem_of_a_teleop_node_at_once_with_file_and_line():
    body = """\
    tree:
      sequence:
        children:
          - teleop:
              modes: [tool_velocity, vehicle_goal, point_aim]
              start_mode: tool_goal
              inputs: [gamepad, gamepad]
              deadman_s: 0.01
              handback: {button: false, service: false}
              speed: 3
    """
    found = issues(body, SIM)
    where = lambda needle: f"m.yaml:{line_of(body, needle)}:"  # noqa: E731
    assert any(f.startswith(where("point_aim")) and "did you mean `point_at`" in f for f in found)
    assert any(f.startswith(where("start_mode")) and "not one of `modes`" in f for f in found)
    assert any(f.startswith(where("inputs")) and "`gamepad` is listed twice" in f for f in found)
    assert any(f.startswith(where("deadman_s")) and "must be >= 0.05" in f for f in found)
    assert any(f.startswith(where("handback")) and "could never hand back" in f for f in found)
    assert any(f.startswith(where("speed")) and "speed" in f for f in found)
    assert any("teleop (operator control) is not bounded" in f for f in found)
    # the gamepad sends velocities only: a goal mode needs the live view
    assert any(f.startswith(where("modes")) and "mode `vehicle_goal` takes a pose or point" in f for f in found)


def test_the_capability_check_knows_which_inputs_a_mission_needs():
    body = "tree:\n  teleop: {modes: [vehicle_velocity], inputs: [gamepad], timeout_s: 60}\n"
    load_mission_text(text(body), "m.yaml", SIM)  # the simulator's config has a pad
    found = issues(body, FIELD)
    assert any("teleop needs device role(s) gamepad, absent from the HAL config" in f for f in found)
    found = issues("tree:\n  teleop: {timeout_s: 60}\n", FIELD)
    assert any("teleop needs an operator input (gamepad, foxglove, keyboard)" in f for f in found)


def test_the_until_of_a_handback_is_checked_like_any_condition():
    body = """\
    tree:
      teleop:
        timeout_s: 60
        handback: {until: {blackboard: {key: seen, equals: true}}}
    """
    found = issues(body)
    assert any("undeclared blackboard key `seen`" in f for f in found)


def test_the_shipped_handover_mission_validates_and_compiles_to_a_teleop_leaf():
    m = load_mission(ROOT / "missions" / "pipe_recovery_handover.yaml", SIM, strict=True)
    root = compile_mission(m, None)
    leaves = [b for b in root.iterate() if isinstance(b, Teleop)]
    assert len(leaves) == 1
    s = leaves[0].settings
    assert s.modes[0] == "vehicle_velocity" and s.timeout_s == 300
    assert s.handback.button and s.handback.service and s.handback.until is not None


def test_the_json_schema_takes_a_teleop_node_and_refuses_a_bad_mode():
    schema = mission_schema()
    doc = yaml.safe_load((ROOT / "missions" / "pipe_recovery_handover.yaml").read_text())
    jsonschema.validate(doc, schema)
    bad = yaml.safe_load(text("tree:\n  teleop: {modes: [jog], timeout_s: 5}\n"))
    with pytest.raises(jsonschema.ValidationError):
        jsonschema.validate(bad, schema)
