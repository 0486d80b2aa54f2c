"""Mission loader regressions of issue 16: `on:` keys, YAML 1.1 words, nesting
and size limits (through subtrees too), error order without knock-ons,
did-you-mean synonyms, bare-word conditions, and the safety lint's warnings
with `strict`."""

from __future__ import annotations

import pytest

from maris_common.yamlsrc import ConfigError
from mission.loader import load_mission_text
from mission.structure import MAX_TREE_DEPTH, MAX_TREE_NODES

HEAD = """\
name: t
safety:
  max_depth_m: 4.0
  min_altitude_m: 0.5
  max_duration_s: 600
  geofence: {north_m: [0, 25], east_m: [0, 12], down_m: [0, 4]}
abort: {action: {run: hold, timeout_s: 5}}
"""


def load(tree: str, extra: str = "", **kw):
    return load_mission_text(HEAD + "tree:\n" + tree + extra, "m.yaml", **kw)


def errors(tree: str, extra: str = "", **kw) -> list[str]:
    with pytest.raises(ConfigError) as exc:
        load(tree, extra, **kw)
    return [str(i) for i in exc.value.issues]


def line_of(text: str, needle: str) -> int:
    return next(i for i, line in enumerate((HEAD + "tree:\n" + text).splitlines(), 1) if needle in line)


# --------------------------------------------------------------------------- the format


def test_one_shot_on_key_is_written_as_documented():
    m = load("  one_shot:\n    on: success\n    child: {wait: {duration_s: 1}}\n")
    assert m.tree.params["on"] == "success"


def test_a_yaml11_word_where_text_is_expected_says_so():
    (err,) = errors("  log: {message: hi, level: off}\n")
    assert "`off`, which YAML reads as the boolean false" in err and "quote" in err


def test_an_exponent_without_a_decimal_point_gets_a_hint():
    (err,) = errors("  wait: {duration_s: 1e3}\n")
    assert "1.0e+3" in err


def test_condition_leaf_as_a_bare_word():
    m = load("  condition: converged\n")
    assert m.tree.kind == "condition" and m.tree.params["predicate"].kind == "converged"
    (err,) = errors("  condition: depth_m\n")
    assert "needs its fields" in err and "{depth_m: {min: 1.0}}" in err


def test_depth_m_suggests_down_m():
    (err,) = errors("  action: {run: survey, timeout_s: 5, targets: {vehicle_goal: {depth_m: 2}}}\n")
    assert "did you mean `down_m`?" in err


def test_a_bad_timeout_is_reported_without_the_knock_on_unbounded_error():
    tree = "  sequence:\n    children:\n      - action:\n          run: survey\n          timeout_s: -5\n"
    (err,) = errors(tree)
    assert err.startswith(f"m.yaml:{line_of(tree, 'timeout_s: -5')}:") and "out of range" in err


def test_a_broken_blackboard_declaration_is_reported_once():
    text = "  condition: {blackboard: {key: mode, equals: 1}}\nblackboard:\n  mode: {type: intt}\n"
    (err,) = errors(text)
    assert "blackboard.mode.type" in err and "did you mean `int`" in err


# --------------------------------------------------------------------------- nesting and size


def nested(levels: int) -> str:
    body = "{wait: {duration_s: 0.1}}"
    for _ in range(levels - 1):
        body = "{retry: {attempts: 1, child: " + body + "}}"
    return "  " + body + "\n"


def test_nesting_up_to_the_limit_loads_and_one_more_is_an_error_at_its_line():
    assert load(nested(MAX_TREE_DEPTH)).tree.kind == "retry"
    (err,) = errors(nested(MAX_TREE_DEPTH + 1))
    assert err.startswith("m.yaml:9:") and f"deeper than {MAX_TREE_DEPTH} levels" in err


def chain(n: int) -> str:
    out = "  {subtree: s0}\nsubtrees:\n"
    out += "".join(f"  s{i}: {{subtree: s{i + 1}}}\n" for i in range(n))
    return out + f"  s{n}: {{wait: {{duration_s: 0.1}}}}\n"


@pytest.mark.slow
@pytest.mark.parametrize("n", [600, 1000])
def test_long_subtree_chains_are_a_nesting_error_not_a_recursion_error(n):
    (err,) = errors(chain(n))
    assert "through subtrees tree -> s0 -> s1" in err and "more)" in err


def test_subtrees_used_twice_at_each_level_are_counted_without_expanding_them():
    text = "  {subtree: d0}\nsubtrees:\n" + "".join(
        f"  d{i}: {{sequence: {{children: [{{subtree: d{i + 1}}}, {{subtree: d{i + 1}}}]}}}}\n" for i in range(15)
    )
    text += "  d15: {wait: {duration_s: 0.1}}\n"
    (err,) = errors(text)
    assert f"more than {MAX_TREE_NODES} nodes" in err


def test_subtree_cycles_are_found_without_recursion():
    text = "  {subtree: a}\nsubtrees:\n  a: {subtree: b}\n  b: {subtree: a}\n"
    assert any("subtree cycle: a -> b -> a" in e for e in errors(text))


# --------------------------------------------------------------------------- safety lint


def warnings_of(tree: str, extra: str = "") -> list[str]:
    return [str(w) for w in load(tree, extra).warnings]


def test_goals_outside_the_envelope_are_warnings():
    ws = warnings_of(
        "  action:\n    run: survey\n    timeout_s: 60\n    targets:\n      waypoints:\n"
        "        - {north_m: 30}\n        - {down_m: 9}\n        - {altitude_m: 0.2}\n        - {east_m: -1}\n"
    )
    assert len(ws) == 4 and all(": warning: " in w for w in ws)
    assert "outside the geofence (north_m 0..25 m)" in ws[0]
    assert "deeper than safety.max_depth_m 4 m" in ws[1]
    assert "below safety.min_altitude_m 0.5 m" in ws[2]
    assert "east_m -1 m is outside the geofence" in ws[3]


def test_a_time_limit_longer_than_the_mission_is_a_warning():
    (w,) = warnings_of("  action: {run: hold, timeout_s: 1.0e+300}\n")
    assert "longer than the whole mission" in w and "never fire" in w


def test_an_unused_subtree_is_a_warning_at_its_name():
    (w,) = warnings_of("  {wait: {duration_s: 1}}\n", "subtrees:\n  spare: {wait: {duration_s: 1}}\n")
    assert w.startswith("m.yaml:11:3: warning:") and "`spare` is never used" in w


def test_a_selector_branch_that_can_never_run_is_a_warning():
    tree = (
        "  selector:\n    children:\n      - sequence: {children: [{log: {message: a}}, {wait: {duration_s: 1}}]}\n"
        "      - action: {name: Never, run: hold, timeout_s: 5}\n"
    )
    (w,) = warnings_of(tree)
    assert w.startswith(f"m.yaml:{line_of(tree, 'Never')}:") and "can never run" in w


def test_a_sequence_child_after_one_that_always_fails_is_a_warning():
    (w,) = warnings_of(
        "  sequence:\n    children:\n      - inverter: {child: {log: {message: x}}}\n      - log: {message: y}\n"
    )
    assert "always fails" in w


def test_strict_turns_warnings_into_errors():
    tree = "  action: {run: hold, timeout_s: 1.0e+300}\n"
    assert len(load(tree).warnings) == 1
    (err,) = errors(tree, strict=True)
    assert "warning:" in err


def test_shipped_missions_have_no_warnings():
    from pathlib import Path

    from mission.loader import load_mission

    for path in sorted((Path(__file__).resolve().parents[2] / "missions").glob("*.yaml")):
        assert load_mission(path, strict=True).warnings == ()
