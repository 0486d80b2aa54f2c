"""The JSON Schema generated from mission/format.py: a valid draft-07 schema,
accepts every shipped mission and template, and agrees with the loader on
field values (checked by an independent validator, the jsonschema package)."""

from __future__ import annotations

from pathlib import Path

import jsonschema
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from maris_common.yamlsrc import ConfigError, load_yaml, parse_yaml
from mission import format as fmt
from mission.jsonschema import mission_schema
from mission.loader import load_mission_text

ROOT = Path(__file__).resolve().parents[2]
SCHEMA = mission_schema()
VALIDATOR = jsonschema.Draft7Validator(SCHEMA)

BASE = """\
name: s
safety:
  max_depth_m: 4.0
  min_altitude_m: 0.5
  max_duration_s: 600
  geofence: {north_m: [0, 25], east_m: [0, 12], down_m: [0, 4]}
abort: {action: {run: hold, timeout_s: 5}}
"""


def test_schema_is_valid_draft7():
    jsonschema.Draft7Validator.check_schema(SCHEMA)


@pytest.mark.parametrize(
    "path",
    sorted((ROOT / "missions").glob("*.yaml")) + sorted((ROOT / "mission" / "templates").glob("*.yaml")),
    ids=lambda p: p.name,
)
def test_shipped_missions_and_templates_match_the_schema(path):
    errors = [e.message for e in VALIDATOR.iter_errors(load_yaml(path).data)]
    assert errors == []


def test_unknown_keys_and_missing_fields_are_refused_by_both():
    for tree in (
        "{wait: {duration_s: 1, extra: 2}}",
        "{wait: {}}",
        "{retry: {attempts: 2}}",
        "{gripper: {command: close}}",
        "{action: {run: survey, timeout_s: 5, targets: {vehicle_goal: {down_m: 1, altitude_m: 2}}}}",
    ):
        text = BASE + f"tree: {tree}\n"
        assert not VALIDATOR.is_valid(parse_yaml(text).data), tree
        with pytest.raises(ConfigError):
            load_mission_text(text)


#: (node body with a FIELD placeholder, node kind, field name): one scalar field each
CASES = [
    ("{{wait: {{duration_s: {v}}}}}", "wait", "duration_s"),
    ("{{timeout: {{duration_s: {v}, child: {{wait: {{duration_s: 1}}}}}}}}", "timeout", "duration_s"),
    ("{{retry: {{attempts: {v}, child: {{wait: {{duration_s: 1}}}}}}}}", "retry", "attempts"),
    ("{{repeat: {{times: {v}, child: {{wait: {{duration_s: 1}}}}}}}}", "repeat", "times"),
    ("{{action: {{run: hold, timeout_s: {v}}}}}", "action", "timeout_s"),
    ("{{gripper: {{command: close, current_limit_a: {v}}}}}", "gripper", "current_limit_a"),
    ("{{log: {{message: x, level: {v}}}}}", "log", "level"),
    ("{{parallel: {{policy: {v}, children: [{{wait: {{duration_s: 1}}}}]}}}}", "parallel", "policy"),
    ("{{sequence: {{memory: {v}, children: [{{wait: {{duration_s: 1}}}}]}}}}", "sequence", "memory"),
]

values = st.one_of(
    st.floats(-1e6, 1e6, allow_nan=False),
    st.integers(-5, 5),
    st.sampled_from([0, 0.0, 1, 1.5, -0.0, 2.0, 3, 1e300]),
    st.booleans(),
    st.sampled_from(["info", "warning", "success_on_one", "success_on_all", "x", "'3'"]),
)


@pytest.mark.slow
@settings(max_examples=150, deadline=None)
@given(st.sampled_from(CASES), values)
def test_loader_and_schema_agree_on_field_values(case, value):
    template, kind, name = case
    assert name in fmt.NODE_FIELDS[kind]
    v = str(value).lower() if isinstance(value, bool) else repr(value) if isinstance(value, float) else value
    text = BASE + "tree: " + template.format(v=v) + "\n"
    data = parse_yaml(text).data
    try:
        load_mission_text(text)
        loads = True
    except ConfigError:
        loads = False
    assert VALIDATOR.is_valid(data) == loads, (text, [e.message for e in VALIDATOR.iter_errors(data)])
