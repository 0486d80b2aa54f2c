"""Bounded, well-placed errors for hostile or broken YAML input (issue 16):
file size, invalid UTF-8 and NUL bytes at their line, nesting depth at its
line, the alias limit applied only to documents with aliases, YAML 1.1 words
as keys and values."""

from __future__ import annotations

import pytest

from maris_common import yamltext
from maris_common.yamlsrc import ConfigError, load_yaml, parse_yaml


def _issue(exc: pytest.ExceptionInfo) -> str:
    assert len(exc.value.issues) >= 1
    return str(exc.value.issues[0])


def test_a_file_over_the_size_limit_is_refused_at_once_with_its_own_message(tmp_path):
    big = tmp_path / "big.yaml"
    row = "  - {north_m: 12.123456, east_m: 6.654321, down_m: 2.0}\n"
    big.write_text("waypoints:\n" + row * (yamltext.MAX_FILE_BYTES // len(row) + 10))
    with pytest.raises(ConfigError) as exc:
        load_yaml(big)
    text = _issue(exc)
    assert text.startswith(f"{big}:1:1:") and "larger than the 2 MB limit" in text and "alias" not in text


def test_many_values_without_aliases_are_not_an_alias_bomb(monkeypatch):
    monkeypatch.setattr(yamltext, "MAX_ALIAS_EXPANSION", 1000)  # small, to keep the test fast
    n = 5000  # more values than aliases may add
    src = parse_yaml("values: [" + ", ".join(["1"] * n) + "]\n", "many.yaml")
    assert len(src.data["values"]) == n
    with pytest.raises(ConfigError) as exc:  # the same count through aliases is refused
        parse_yaml("a: &a [" + ", ".join(["1"] * 100) + "]\nb: [" + ", ".join(["*a"] * 50) + "]\n", "al.yaml")
    assert "alias bomb" in _issue(exc)


def test_aliases_that_expand_too_much_are_refused_at_the_first_alias():
    lines = ['a0: &a0 ["x", "x", "x", "x", "x", "x", "x", "x", "x", "x"]']
    for i in range(1, 7):
        lines.append(f"a{i}: &a{i} [{', '.join([f'*a{i - 1}'] * 10)}]")
    with pytest.raises(ConfigError) as exc:
        parse_yaml("\n".join(lines) + "\n", "bomb.yaml")
    assert _issue(exc).startswith("bomb.yaml:2:10:") and "alias bomb" in _issue(exc)


def test_a_few_aliases_are_fine():
    src = parse_yaml("goal: &g {north_m: 1}\nwaypoints: [*g, *g]\n", "a.yaml")
    assert src.data["waypoints"] == [{"north_m": 1}, {"north_m": 1}]


@pytest.mark.parametrize("depth", [yamltext.MAX_DEPTH + 1, 10_000])
def test_deep_flow_lists_name_their_line(depth):
    text = "a: 1\nb: 2\nc: " + "[" * depth + "]" * depth + "\n"
    with pytest.raises(ConfigError) as exc:
        parse_yaml(text, "deep.yaml")
    assert _issue(exc).startswith("deep.yaml:3:") and "nested" in _issue(exc)


def test_deep_block_mappings_name_the_line_past_the_limit():
    text = "".join("  " * i + f"k{i}:\n" for i in range(250)) + "  " * 250 + "leaf\n"
    with pytest.raises(ConfigError) as exc:
        parse_yaml(text, "deep.yaml")
    line = int(_issue(exc).split(":")[1])
    assert line == yamltext.MAX_DEPTH + 1 and "nested more than 128 levels deep" in _issue(exc)


def test_a_recursive_alias_is_refused():
    with pytest.raises(ConfigError) as exc:
        parse_yaml("a: &a [*a]\n", "r.yaml")
    assert _issue(exc).startswith("r.yaml:")


def test_nul_bytes_and_control_characters_are_reported_where_they_are():
    with pytest.raises(ConfigError) as exc:
        parse_yaml("name: x\nsafety:\n  a: b\x00c\n  d: \x07\n", "nul.yaml")
    issues = [str(i) for i in exc.value.issues]
    assert issues[0].startswith("nul.yaml:3:7:") and "NUL byte" in issues[0]
    assert issues[1].startswith("nul.yaml:4:6:") and "U+0007" in issues[1]


def test_invalid_utf8_is_reported_at_its_line_and_column(tmp_path):
    f = tmp_path / "latin1.yaml"
    f.write_bytes("name: x\ndescription: café au lait\n".encode("latin-1"))
    with pytest.raises(ConfigError) as exc:
        load_yaml(f)
    assert _issue(exc).startswith(f"{f}:2:17:") and "not valid UTF-8 (byte 0xe9)" in _issue(exc)


def test_utf16_gets_a_hint(tmp_path):
    f = tmp_path / "u16.yaml"
    f.write_bytes("name: x\n".encode("utf-16"))
    with pytest.raises(ConfigError) as exc:
        load_yaml(f)
    assert "UTF-16" in _issue(exc)


def test_yaml11_boolean_words_stay_words_as_keys():
    src = parse_yaml("on: success\nyes: 1\nOff: 2\nn: 3\n", "k.yaml")
    assert src.data == {"on": "success", "yes": 1, "Off": 2, "n": 3}
    assert src.key_mark(("yes",)).line == 2


def test_yaml11_boolean_words_as_values_are_remembered():
    src = parse_yaml("a: off\nb: true\nc: 'no'\n", "v.yaml")
    assert src.data == {"a": False, "b": True, "c": "no"}
    assert src.bool_words == {("a",): "off"}


def test_merge_keys_get_a_clear_message():
    with pytest.raises(ConfigError) as exc:
        parse_yaml("base: &b {x: 1}\nother:\n  <<: *b\n", "m.yaml")
    assert _issue(exc).startswith("m.yaml:3:3:") and "merge keys" in _issue(exc)


def test_the_pure_python_parser_gives_the_same_answers(monkeypatch):
    """Without LibYAML (PyYAML built without it), the same values, keys and errors."""
    import yaml

    monkeypatch.setattr(yamltext, "FAST_LOADER", yaml.SafeLoader)
    assert parse_yaml("on: [1, 1.5, x, off]\n", "p.yaml").data == {"on": [1, 1.5, "x", False]}
    for text, where in (("a: " + "[" * 300 + "]" * 300 + "\n", "p.yaml:1:"), ("a: b\x00\n", "p.yaml:1:5:")):
        with pytest.raises(ConfigError) as exc:
            parse_yaml(text, "p.yaml")
        assert _issue(exc).startswith(where)
