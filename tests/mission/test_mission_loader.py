"""Mission loader: shipped missions, error positions, all errors at once,
suggestions, references, safety lint, HAL roles."""

from __future__ import annotations

import textwrap
from pathlib import Path

import pytest

from maris_common.yamlsrc import ConfigError, format_path
from mission.loader import load_mission, load_mission_text

ROOT = Path(__file__).resolve().parents[2]
SHIPPED = sorted((ROOT / "missions").glob("*.yaml"))

HEADER = """\
name: t
safety:
  max_depth_m: 10
  min_altitude_m: 0.5
  max_duration_s: 60
  geofence: {north_m: [-5, 5], east_m: [-5, 5], down_m: [0, 10]}
abort:
  action: {run: hold, timeout_s: 5}
"""


def load(body: str, header: str = HEADER, **kw):
    return load_mission_text(header + textwrap.dedent(body), "m.yaml", **kw)


def issues(body: str, header: str = HEADER, **kw) -> list[str]:
    with pytest.raises(ConfigError) as exc:
        load(body, header, **kw)
    return [str(i) for i in exc.value.issues]


def line_of(text: str, needle: str) -> int:
    return next(i for i, line in enumerate(text.splitlines(), 1) if needle in line)


@pytest.mark.parametrize("path", SHIPPED, ids=lambda p: p.name)
def test_shipped_missions_validate(path):
    mission = load_mission(path)
    assert mission.abort is not None and mission.safety.max_duration_s > 0
    assert {n.params["run"] for n in mission.tree.walk() if n.kind == "action"} <= set(mission.action_names)


def test_shipped_missions_include_the_maris_one():
    assert {"maris_pipe_recovery.yaml", "survey_only.yaml"} <= {p.name for p in SHIPPED}
    m = load_mission(ROOT / "missions" / "maris_pipe_recovery.yaml")
    kinds = [n.kind for n in m.tree.walk()]
    assert "retry" in kinds and "gripper" in kinds and "condition" in kinds
    assert m.rates.arm_hz >= 100 and 10 <= m.rates.vehicle_hz <= 20
    assert m.blackboard["grasp_pose"].type == "pose"


def test_mission_fields_are_filled():
    m = load("""\
        rates: {tree_hz: 5, vehicle_hz: 20, arm_hz: 200}
        blackboard:
          n: 3
          speed: 0.5
          target: {type: point, value: [1, 2, 3]}
        tree:
          wait: {duration_s: 1}
        """)
    assert (m.rates.tree_hz, m.rates.vehicle_hz, m.rates.arm_hz) == (5, 20, 200)
    assert m.initial_blackboard() == {"n": 3, "speed": 0.5, "target": [1.0, 2.0, 3.0]}
    assert m.safety.geofence.contains([0, 0, 5]) and not m.safety.geofence.contains([6, 0, 5])
    assert m.safety.watchdog_s == {"navigation": 0.5, "joints": 0.2}
    assert m.model is None and m.actions_file is None


def test_unknown_action_points_at_run_with_suggestion():
    body = """\
        tree:
          sequence:
            children:
              - wait: {duration_s: 1}
              - action: {run: grap, timeout_s: 10}
        """
    text = HEADER + textwrap.dedent(body)
    found = issues(body)
    assert len(found) == 1
    line = line_of(text, "run: grap")
    col = text.splitlines()[line - 1].index("grap") + 1
    assert found[0] == (
        f"m.yaml:{line}:{col}: tree.sequence.children[1].action.run: unknown action `grap` (did you mean `grasp`?); "
        "the actions file defines: survey, grasp, lift, transport, hold, jog_tool, jog_tool_vehicle, jog_vehicle, "
        "reach, look_at"
    )


def test_all_errors_are_reported_at_once_in_file_order():
    text = textwrap.dedent("""\
        name: many
        rates: {arm_hz: 20}
        safety:
          max_depth_m: ten
          min_altitude_m: 0.5
          max_duration_s: 60
          geofence: {north_m: [5, -5], east_m: [-5, 5], down_m: [0, 10]}
        tree:
          sequnce:
            children: []
        """)
    found = issues("", header=text)
    assert [":".join(f.split(":")[1:3]) for f in found] == ["1:1", "2:17", "4:16", "7:23", "9:3"]
    joined = "\n".join(found)
    assert "rates.arm_hz: 20 is out of range" in joined
    assert "safety.max_depth_m: expected a finite number, got a string 'ten'" in joined
    assert "low bound 5.0 must be below high bound -5.0" in joined
    assert "unknown node kind `sequnce` (did you mean `sequence`?)" in joined
    assert "missing required section `abort`" in joined


@pytest.mark.parametrize(
    "body,expected",
    [
        ("tree:\n  action: {run: grasp}\n", "action `grasp` is not bounded"),
        ("tree:\n  action: {run: grasp, timeout_s: -1}\n", "tree.action.timeout_s: -1 is out of range: must be > 0.0"),
        ("tree:\n  action: {run: grasp, timout_s: 3}\n", "unknown key `timout_s` (did you mean `timeout_s`?)"),
        ("tree:\n  subtree: stow\n", "unknown subtree `stow`"),
        ("tree:\n  condition: {depth_m: {}}\n", "`depth_m` needs `min`, `max` or both"),
        ("tree:\n  condition: {converged: {for_s: -1}}\n", "converged.for_s: -1 is out of range: must be >= 0.0"),
        ("tree:\n  condition: {converged: {for_s: 1}}\n", "`for_s` only works in an action's `until`"),
        ("tree:\n  condition: {converged: {max_eror: 0.1}}\n", "unknown key `max_eror` (did you mean `max_error`?)"),
        ("tree:\n  condition: {detcted: {}}\n", "unknown condition `detcted` (did you mean `detected`?)"),
        ("tree:\n  condition: {blackboard: {key: n, at_most: 3}}\n", "undeclared blackboard key `n`"),
        ("tree:\n  gripper: {command: close}\n", "missing required field `current_limit_a`"),
        ("tree:\n  gripper: {command: preshape}\n", "missing required field `shape`"),
        ("tree:\n  gripper: {command: open, shape: x}\n", "`shape` is only used with `command: preshape`"),
        ("tree:\n  retry: {attempts: 0, child: {wait: {duration_s: 1}}}\n", "0 is out of range: must be >= 1"),
        ("tree:\n  retry: {attempts: 2.5, child: {wait: {duration_s: 1}}}\n", "expected an integer"),
        ("tree:\n  retry: {attempts: 2}\n", "missing required field `child`"),
        ("tree:\n  sequence: {children: []}\n", "expected a non-empty list of nodes"),
        (
            "tree:\n  parallel: {policy: success_on_any, children: [{wait: {duration_s: 1}}]}\n",
            "did you mean `success_on_one`",
        ),
        ("tree:\n  wait: {duration_s: 1}\n  log: {message: x}\n", "exactly one key"),
        ("tree:\n  set: {key: k, value: 1, add: 1}\n", "exactly one of `value`"),
        ("tree:\n  guard: {child: {wait: {duration_s: 1}}}\n", "missing required field `condition`"),
        ("tree: [1, 2]\n", "expected a node"),
        (
            "tree:\n  action: {run: survey, timeout_s: 9, targets: {vehicle_goal: {down_m: 1, altitude_m: 2}}}\n",
            "either `down_m` or `altitude_m`",
        ),
        ("tree:\n  action: {run: survey, timeout_s: 9, targets: {waypoints: []}}\n", "non-empty list of goals"),
        (
            "tree:\n  action: {run: grasp, timeout_s: 9, targets: {tool_goal_from: pose}}\n",
            "undeclared blackboard key `pose`",
        ),
    ],
)
def test_single_errors(body, expected):
    found = issues(body)
    assert any(expected in f for f in found), found


def test_type_mismatches_on_blackboard_keys():
    found = issues("""\
        blackboard:
          n: 1
          label: abc
          p: {type: pose}
        tree:
          sequence:
            children:
              - set: {key: n, value: "x"}
              - set: {key: label, add: 1}
              - condition: {blackboard: {key: label, below: 3}}
              - action: {run: grasp, timeout_s: 5, targets: {tool_goal_from: n}}
              - condition: {detected: {store_as: label}}
        """)
    joined = "\n".join(found)
    assert "blackboard key `n` is an int: value 'x' is not an int" in joined
    assert joined.count("blackboard key `label` is a str, here an int or a float is needed") == 2
    assert "blackboard key `n` is an int, here a pose is needed" in joined
    assert "blackboard key `label` is a str, here a pose is needed" in joined


def test_bad_blackboard_declarations():
    found = issues("""\
        blackboard:
          p: {type: pose, value: [1, 2]}
          q: {type: quaternion}
          l: [1, 2]
        tree:
          wait: {duration_s: 1}
        """)
    joined = "\n".join(found)
    assert "expected a pose (4x4 list of rows, world NED)" in joined
    assert "unknown value `quaternion`" in joined
    assert "cannot tell the type of a list" in joined


def test_safety_lint_accepts_timeout_or_guard_ancestors_and_checks_subtrees():
    load("""\
        tree:
          sequence:
            children:
              - timeout: {duration_s: 10, child: {action: {run: grasp}}}
              - guard:
                  condition: {depth_m: {max: 8}}
                  child: {subtree: fold}
        subtrees:
          fold: {action: {run: transport}}
        """)
    found = issues("""\
        tree:
          sequence:
            children:
              - subtree: fold
        subtrees:
          fold: {action: {run: transport}}
        """)
    assert len(found) == 1 and "not bounded" in found[0] and "fold" in found[0]


def test_abort_path_is_linted_too():
    header = HEADER.replace("abort:\n  action: {run: hold, timeout_s: 5}\n", "abort:\n  action: {run: hold}\n")
    found = issues("tree:\n  wait: {duration_s: 1}\n", header=header)
    assert len(found) == 1 and found[0].startswith("m.yaml:8:") and "abort.action" in found[0]


def test_subtree_cycles_are_reported():
    found = issues("""\
        tree: {subtree: a}
        subtrees:
          a: {subtree: b}
          b: {sequence: {children: [{subtree: a}]}}
        """)
    assert any("subtree cycle" in f for f in found)


@pytest.mark.parametrize("name", ["x" * 5000, "a\\0b", "/dev/null", "/etc/hostname"])
def test_odd_file_names_are_errors_not_crashes(name):
    for key in ("model", "actions_file"):
        try:
            load(f'{key}: "{name}"\ntree:\n  wait: {{duration_s: 1}}\n')
        except ConfigError as exc:
            assert any(key in str(i) for i in exc.issues)
        else:
            raise AssertionError(f"{key}: {name[:20]} accepted")


def test_missing_model_file_is_reported(tmp_path):
    found = issues("model: nowhere.urdf\ntree:\n  wait: {duration_s: 1}\n")
    assert any("model: file not found" in f for f in found)


def test_hal_roles_are_checked():
    class Hal:
        roles = frozenset({"vehicle", "arm"})

    found = issues(
        """\
        tree:
          sequence:
            children:
              - gripper: {command: open}
              - condition: {detected: {}}
              - condition: {force_n: {max: 50}}
        """,
        hal_config=Hal(),
    )
    joined = "\n".join(found)
    assert "gripper command needs device role(s) gripper" in joined
    assert "condition `detected` needs device role(s) detector" in joined
    assert "condition `force_n` needs device role(s) wrench_sensor" in joined


def test_watchdog_on_absent_device_with_hal():
    class Hal:
        roles = frozenset({"vehicle", "arm"})

    header = HEADER.replace("  geofence:", "  watchdog_s: {gripper: 0.5}\n  geofence:")
    found = issues("tree:\n  wait: {duration_s: 1}\n", header=header, hal_config=Hal())
    assert len(found) == 1 and "no `gripper` device" in found[0]


def test_hal_config_file_is_loaded(tmp_path):
    hal = tmp_path / "sim.yaml"
    hal.write_text("devices:\n  vehicle: {driver: sim}\n  arm: {driver: sim}\nsim: {scenario: pool_clear}\n")
    found = issues("tree:\n  gripper: {command: open}\n", hal_config=hal)
    assert any("needs device role(s) gripper" in f for f in found)


def test_explicit_actions_file_names_are_used(tmp_path):
    actions = tmp_path / "actions.yaml"
    actions.write_text(
        "hierarchy:\n  - {name: vehicle_stop, type: vehicle_velocity_minimization}\n"
        "actions:\n  dock: [vehicle_stop]\n  hold: [vehicle_stop]\n"
    )
    (tmp_path / "m.yaml").write_text(
        HEADER + f"actions_file: {actions}\ntree:\n  action: {{run: survey, timeout_s: 3}}\n"
    )
    with pytest.raises(ConfigError) as exc:
        load_mission(tmp_path / "m.yaml")
    assert "unknown action `survey`" in str(exc.value) and "defines: dock, hold" in str(exc.value)


def test_broken_actions_file_is_reported_not_raised(tmp_path):
    actions = tmp_path / "actions.yaml"
    actions.write_text("actions:\n  dock: {}\n")
    (tmp_path / "m.yaml").write_text(
        HEADER + f"actions_file: {actions}\ntree:\n  action: {{run: dock, timeout_s: 3}}\n"
    )
    with pytest.raises(ConfigError) as exc:
        load_mission(tmp_path / "m.yaml")
    assert all("actions_file" in str(i) for i in exc.value.issues)


def test_unsafe_yaml_is_refused():
    found = issues("tree: !!python/object/apply:os.system ['echo hi']\n")
    assert len(found) == 1 and "unsupported YAML" in found[0] or "could not determine a constructor" in found[0]


def test_key_errors_point_at_the_key_value_errors_at_the_value():
    text = HEADER + textwrap.dedent("""\
        tree:
          sequence:
            children:
              - action:
                  run: grasp
                  timout_s: 3
              - wiat:
                  duration_s: 1
              - condition:
                  altitud_m:
                    min: 1
              - wait: {duration_s: -2}
        """)
    with pytest.raises(ConfigError) as exc:
        load_mission_text(text, "m.yaml")
    got = {format_path(i.path): (i.mark.line, i.mark.column) for i in exc.value.issues}
    lines = text.splitlines()

    def at(needle: str, col_of: str) -> tuple[int, int]:
        n = line_of(text, needle)
        return n, lines[n - 1].index(col_of) + 1

    assert got["tree.sequence.children[0].action.timout_s"] == at("timout_s: 3", "timout_s")
    assert got["tree.sequence.children[1].wiat"] == at("- wiat:", "wiat")
    assert got["tree.sequence.children[2].condition.altitud_m"] == at("altitud_m:", "altitud_m")
    assert got["tree.sequence.children[3].wait.duration_s"] == at("duration_s: -2", "-2")
    assert "tree.sequence.children[0].action" in got  # and the action is unbounded (its timeout was misspelt)
