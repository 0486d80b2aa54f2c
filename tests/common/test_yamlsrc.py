"""YAML with source positions: marks, duplicate keys, unsafe tags, suggestions."""

from __future__ import annotations

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from maris_common.yamlsrc import ConfigError, format_path, load_yaml, parse_yaml, suggest, unknown_keys


def test_marks_point_at_values():
    src = parse_yaml("a: 1\nb:\n  - x: 2\n    yy: 3\n", "f.yaml")
    assert src.data == {"a": 1, "b": [{"x": 2, "yy": 3}]}
    m = src.mark(("b", 0, "yy"))
    assert (m.file, m.line, m.column) == ("f.yaml", 4, 9)
    # A path below a scalar falls back to the nearest ancestor.
    assert src.mark(("b", 0, "yy", "deeper")) == m


def test_duplicate_key_is_an_error_with_position():
    with pytest.raises(ConfigError) as err:
        parse_yaml("a: 1\nb: 2\na: 3\n", "d.yaml")
    assert "d.yaml:3:1" in str(err.value)
    assert "duplicate key" in str(err.value)


def test_python_tags_are_never_constructed():
    with pytest.raises(ConfigError) as err:
        parse_yaml("a: !!python/object/apply:os.system ['echo hacked']\n", "x.yaml")
    assert "x.yaml:1" in str(err.value)


def test_syntax_error_names_line():
    with pytest.raises(ConfigError) as err:
        parse_yaml("a: [1, 2\nb: 3\n", "s.yaml")
    assert str(err.value).startswith("s.yaml:")


def test_missing_file_is_a_config_error(tmp_path):
    with pytest.raises(ConfigError) as err:
        load_yaml(tmp_path / "nope.yaml")
    assert "cannot read file" in str(err.value)


def test_suggestions_and_unknown_keys():
    assert suggest("grap", ["grasp", "survey"]) == " (did you mean `grasp`?)"
    assert suggest("zzz", ["grasp"]) == ""
    src = parse_yaml("gian: 1\nok: 2\n", "k.yaml")
    issues = unknown_keys(src, src.data, (), ["gain", "ok"])
    assert len(issues) == 1
    assert "did you mean `gain`" in str(issues[0])
    assert str(issues[0]).startswith("k.yaml:1:")


def test_format_path():
    assert format_path(("levels", 3, "gain")) == "levels[3].gain"
    assert format_path(()) == "<root>"


@settings(max_examples=100, deadline=None)
@given(st.text(max_size=200))
def test_arbitrary_text_never_raises_anything_but_config_error(text):
    try:
        parse_yaml(text, "fuzz.yaml")
    except ConfigError as err:  # and it names the file and a position
        assert err.issues and all(str(i).startswith("fuzz.yaml:") for i in err.issues)


def test_alias_bomb_is_refused():
    lines = ['a0: &a0 ["x", "x", "x", "x", "x", "x", "x", "x", "x", "x"]']
    for i in range(1, 9):
        prev = f"*a{i - 1}"
        lines.append(f"a{i}: &a{i} [{', '.join([prev] * 10)}]")
    with pytest.raises(ConfigError) as err:
        parse_yaml("\n".join(lines) + "\n", "bomb.yaml")
    assert "alias" in str(err.value)


def test_recursive_alias_is_refused():
    with pytest.raises(ConfigError):
        parse_yaml("a: &x [*x]\n", "rec.yaml")
