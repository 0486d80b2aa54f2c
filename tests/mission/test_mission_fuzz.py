"""Generated YAML never makes the loader raise anything but ConfigError,
every issue names a position inside the file, and every mission that loads
also compiles."""

from __future__ import annotations

import pytest
import yaml
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from maris_common.yamlsrc import ConfigError
from mission.compiler import compile_abort, compile_mission
from mission.loader import load_mission_text
from mission.spec import NODE_KINDS, PREDICATE_KINDS

KEYS = (
    list(NODE_KINDS)
    + list(PREDICATE_KINDS)
    + [
        "name",
        "children",
        "child",
        "run",
        "timeout_s",
        "duration_s",
        "attempts",
        "times",
        "targets",
        "until",
        "waypoints",
        "vehicle_goal",
        "north_m",
        "down_m",
        "altitude_m",
        "key",
        "value",
        "add",
        "command",
        "shape",
        "current_limit_a",
        "condition",
        "policy",
        "memory",
        "use",
        "message",
        "min",
        "max",
        "store_as",
        "type",
        "safety",
        "tree",
        "abort",
        "subtrees",
        "blackboard",
        "rates",
        "max_depth_m",
        "geofence",
        "tool_goal_from",
    ]
)
scalars = st.one_of(
    st.none(),
    st.booleans(),
    st.integers(-5, 1000),
    st.floats(allow_nan=True, allow_infinity=True),
    st.sampled_from(
        ["grasp", "survey", "grap", "hold", "close", "x", "", "pose", "success_on_one", "converged", "detected"]
    ),
)
values = st.recursive(
    scalars,
    lambda inner: st.one_of(st.lists(inner, max_size=4), st.dictionaries(st.sampled_from(KEYS), inner, max_size=4)),
    max_leaves=25,
)
VALID = {
    "name": "fuzz",
    "safety": {
        "max_depth_m": 5,
        "min_altitude_m": 0.5,
        "max_duration_s": 60,
        "geofence": {"north_m": [0, 1], "east_m": [0, 1], "down_m": [0, 5]},
    },
    "tree": {"wait": {"duration_s": 1}},
    "abort": {"action": {"run": "hold", "timeout_s": 5}},
}


def check(text: str) -> None:
    """Only ConfigError with in-file positions; and what loads also compiles."""
    try:
        mission = load_mission_text(text, "f.yaml")
        compile_mission(mission, None)
        compile_abort(mission, None)
    except ConfigError as exc:
        assert exc.issues
        lines = max(1, text.count("\n") + 1)
        for issue in exc.issues:
            assert issue.mark.file == "f.yaml" and 1 <= issue.mark.line <= lines + 1, issue


@pytest.mark.slow
@settings(max_examples=80, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(st.dictionaries(st.sampled_from(KEYS), values, max_size=6))
def test_random_documents_only_give_config_errors(doc):
    check(yaml.safe_dump(doc))


@pytest.mark.slow
@settings(max_examples=80, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(st.sampled_from(["tree", "abort", "safety", "blackboard", "subtrees", "rates"]), values)
def test_one_section_replaced_by_junk(section, junk):
    doc = dict(VALID)
    doc[section] = junk
    check(yaml.safe_dump(doc))


@settings(max_examples=60, deadline=None)
@given(st.text(max_size=200))
def test_arbitrary_text_only_gives_config_errors(text):
    check(text)


@settings(max_examples=60, deadline=None)
@given(st.integers(0, 400), st.sampled_from(["", ":", "- ", "{", "]", "!!python/name:os.system ", "\t", "&a ", "*a"]))
def test_corrupted_shipped_mission_only_gives_config_errors(pos, junk):
    from pathlib import Path

    text = (Path(__file__).resolve().parents[2] / "missions" / "maris_pipe_recovery.yaml").read_text()
    pos = min(pos * 10, len(text))
    check(text[:pos] + junk + text[pos:])


def _paths(data, prefix=()):
    yield prefix
    if isinstance(data, dict):
        for k, v in data.items():
            yield from _paths(v, prefix + (k,))
    elif isinstance(data, list):
        for i, v in enumerate(data):
            yield from _paths(v, prefix + (i,))


def _replace(data, path, value):
    if not path:
        return value
    import copy

    out = copy.deepcopy(data)
    node = out
    for part in path[:-1]:
        node = node[part]
    if value is _DELETE:
        del node[path[-1]]
    else:
        node[path[-1]] = value
    return out


_DELETE = object()
_GUARDED = yaml.safe_load(
    (__import__("pathlib").Path(__file__).resolve().parents[2] / "missions" / "pipe_recovery_guarded.yaml").read_text()
)
_GUARDED_PATHS = [p for p in _paths(_GUARDED) if p]


@pytest.mark.slow
@settings(max_examples=80, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(st.sampled_from(_GUARDED_PATHS), st.one_of(st.just(_DELETE), values))
def test_mutated_shipped_mission_only_gives_config_errors(path, value):
    check(yaml.safe_dump(_replace(_GUARDED, path, value)))
