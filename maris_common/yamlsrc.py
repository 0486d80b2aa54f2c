"""YAML loading that remembers where every value came from.

All user-written files (missions, actions, scenarios, HAL configs) are read with
:func:`load_yaml`, so that any error can name ``file:line:column`` and the field.
Only ``yaml.SafeLoader`` is used: nothing in a file is ever executed.

Paths into the data are tuples of keys and list indices, e.g.
``("levels", 3, "gain")``; :func:`format_path` renders them as ``levels[3].gain``.
"""

from __future__ import annotations

import difflib
import re
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import yaml

from maris_common import yamltext

PathT = tuple[Any, ...]


@dataclass(frozen=True)
class Mark:
    """A position in a source file; line and column are 1-based."""

    file: str
    line: int
    column: int

    def __str__(self) -> str:
        return f"{self.file}:{self.line}:{self.column}"


def format_path(path: Sequence[Any]) -> str:
    """Render a data path as ``a.b[2].c`` (``<root>`` for the empty path)."""
    out = ""
    for part in path:
        if isinstance(part, int):
            out += f"[{part}]"
        else:
            out += ("." if out else "") + str(part)
    return out or "<root>"


@dataclass(frozen=True)
class ConfigIssue:
    """One problem in a file: where, which field, what is wrong.

    ``severity`` is ``error`` (the file is refused) or ``warning`` (accepted,
    but probably not what the author meant; rendered with ``warning:``)."""

    mark: Mark
    path: PathT
    message: str
    severity: str = "error"

    def __str__(self) -> str:
        tag = "warning: " if self.severity == "warning" else ""
        return f"{self.mark}: {tag}{format_path(self.path)}: {self.message}"

    def to_dict(self) -> dict:
        """JSON-able form (``--json`` outputs)."""
        return {
            "file": self.mark.file,
            "line": self.mark.line,
            "column": self.mark.column,
            "field": format_path(self.path),
            "message": self.message,
            "severity": self.severity,
        }


class ConfigError(Exception):
    """One or more problems in user-written files. ``str()`` lists them all,
    one per line, as ``file:line:column: field: message``."""

    def __init__(self, issues: Iterable[ConfigIssue], warnings: Iterable[ConfigIssue] = ()):
        self.issues: list[ConfigIssue] = list(issues)
        #: Warnings found alongside the errors (not part of ``str()``).
        self.warnings: list[ConfigIssue] = list(warnings)
        super().__init__("\n".join(str(i) for i in self.issues))


@dataclass
class Located:
    """Parsed YAML data plus the source mark of every node."""

    data: Any
    file: str
    marks: dict[PathT, Mark] = field(default_factory=dict)
    #: Mark of each mapping *key* (``marks`` holds the values'), by the path of its value.
    key_marks: dict[PathT, Mark] = field(default_factory=dict)
    #: Values YAML 1.1 read as booleans from a bare word other than true/false
    #: (``on``, ``off``, ``yes``, ``no``): path -> the word as written.
    bool_words: dict[PathT, str] = field(default_factory=dict)

    def mark(self, path: Sequence[Any]) -> Mark:
        """Mark of ``path``, or of its nearest ancestor that has one."""
        p = tuple(path)
        while p not in self.marks and p:
            p = p[:-1]
        return self.marks.get(p, Mark(self.file, 1, 1))

    def issue(self, path: Sequence[Any], message: str) -> ConfigIssue:
        return ConfigIssue(self.mark(path), tuple(path), message)

    def key_mark(self, path: Sequence[Any]) -> Mark:
        """Mark of the *key* of ``path`` (e.g. for an unknown key), else of its value."""
        return self.key_marks.get(tuple(path)) or self.mark(path)


_PLAIN_COLLECTION_TAGS = ("tag:yaml.org,2002:map", "tag:yaml.org,2002:seq")
_BOOL_TAG = "tag:yaml.org,2002:bool"
_STR_TAG, _INT_TAG, _FLOAT_TAG = "tag:yaml.org,2002:str", "tag:yaml.org,2002:int", "tag:yaml.org,2002:float"
_PLAIN_INT = re.compile(r"[-+]?(0|[1-9][0-9]*)\Z")
_PLAIN_FLOAT = re.compile(r"[-+]?([0-9]+\.[0-9]*|\.[0-9]+)([eE][-+][0-9]+)?\Z")

#: Kept for callers of the old name: the most values aliases may add.
MAX_NODES = yamltext.MAX_ALIAS_EXPANSION


class _Builder:
    """Builds plain Python values from composed YAML nodes, recording the mark
    of every value and key, and the bare words YAML 1.1 read as booleans.

    Keys are always text: a plain key that YAML 1.1 would read as a boolean
    (``on``, ``off``, ``yes``, ``no``, ``true``, ``false``) stays the word as
    written, so ``on: success`` means the field ``on``.
    """

    def __init__(self, file: str):
        self.file = file
        self.marks: dict[PathT, Mark] = {}
        self.key_marks: dict[PathT, Mark] = {}
        self.bool_words: dict[PathT, str] = {}
        self.issues: list[ConfigIssue] = []
        self._ctor = yaml.constructor.SafeConstructor()

    def mark_of(self, node: yaml.Node) -> Mark:
        m = node.start_mark
        return Mark(self.file, m.line + 1, m.column + 1)

    def build(self, node: yaml.Node, path: PathT, depth: int) -> Any:
        """``depth`` is bounded: the text and, with aliases, the expansion were measured first."""
        mark = self.mark_of(node)
        self.marks[path] = mark
        if isinstance(node, (yaml.MappingNode, yaml.SequenceNode)) and node.tag not in _PLAIN_COLLECTION_TAGS:
            self.issues.append(
                ConfigIssue(
                    mark, path, f"unsupported YAML tag {node.tag!r}: only plain mappings, lists and scalars are allowed"
                )
            )
            return None
        if isinstance(node, yaml.MappingNode):
            return self._mapping(node, path, depth)
        if isinstance(node, yaml.SequenceNode):
            return [self.build(v, path + (i,), depth + 1) for i, v in enumerate(node.value)]
        value = self._scalar(node)
        if isinstance(value, bool) and not node.style and node.value.lower() not in ("true", "false"):
            self.bool_words[path] = node.value
        return value

    def _scalar(self, node: yaml.ScalarNode) -> Any:
        """The value of a scalar: plain text and decimal numbers directly (the
        bulk of a large file), everything else through PyYAML's safe constructor."""
        tag, text = node.tag, node.value
        if tag == _STR_TAG:
            return text
        if tag == _FLOAT_TAG and _PLAIN_FLOAT.match(text):
            return float(text)
        if tag == _INT_TAG and _PLAIN_INT.match(text):
            return int(text)
        return self._ctor.construct_object(node, deep=True)

    def _mapping(self, node: yaml.MappingNode, path: PathT, depth: int) -> dict:
        out: dict[Any, Any] = {}
        for key_node, value_node in node.value:
            km = self.mark_of(key_node)
            if not isinstance(key_node, yaml.ScalarNode):
                self.issues.append(
                    ConfigIssue(km, path, "unsupported key: a key must be a word or a number, not a mapping or list")
                )
                continue
            if key_node.tag == "tag:yaml.org,2002:merge":
                self.issues.append(
                    ConfigIssue(
                        km, path, "YAML merge keys (`<<`) are not supported: write the fields out (or use a subtree)"
                    )
                )
                continue
            if key_node.tag == _BOOL_TAG and not key_node.style:  # plain: None (PyYAML) or "" (LibYAML)
                key: Any = key_node.value  # `on:` is the key "on", not True
            else:
                key = self._ctor.construct_object(key_node, deep=True)
            if not isinstance(key, (str, int, float)) or isinstance(key, bool):
                self.issues.append(ConfigIssue(km, path, f"unsupported key {key!r}"))
                continue
            if key in out:
                self.issues.append(ConfigIssue(km, path + (key,), "duplicate key (the later value would silently win)"))
                continue
            self.key_marks.setdefault(path + (key,), km)
            out[key] = self.build(value_node, path + (key,), depth + 1)
        return out


_TOO_DEEP = f"nested more than {yamltext.MAX_DEPTH} levels deep (mappings and lists); flatten the document"


def _issue_at(file: str, line: int, column: int, message: str) -> ConfigIssue:
    return ConfigIssue(Mark(file, line, column), (), message)


def _yaml_error(file: str, exc: yaml.YAMLError) -> ConfigIssue:
    if isinstance(exc, yaml.MarkedYAMLError):
        m = exc.problem_mark or exc.context_mark
        line, column = (m.line + 1, m.column + 1) if m else (1, 1)
        what = exc.problem or exc.context or str(exc)
        if "maximum nesting depth" in str(what):  # LibYAML's own limit, met while scanning ahead
            return _issue_at(file, line, column, _TOO_DEEP)
        prefix = "unsupported YAML" if isinstance(exc, yaml.constructor.ConstructorError) else "YAML syntax error"
        return _issue_at(file, line, column, f"{prefix}: {what}")
    return _issue_at(file, 1, 1, f"YAML error: {exc}")


def parse_yaml(text: str, file: str = "<string>") -> Located:
    """Parse YAML text (safe loader only), recording a mark for every node.

    Raises :class:`ConfigError` for forbidden characters, syntax errors, too
    deep nesting, alias bombs, duplicate keys and unsupported constructs (tags
    that would build Python objects are rejected by the safe loader); every
    issue names its line and column.
    """
    bad = yamltext.bad_characters(text)
    if bad:
        raise ConfigError([_issue_at(file, p.line, p.column, p.message) for p in bad])
    try:
        scan = yamltext.scan_events(text)
        if scan.too_deep is not None:
            raise ConfigError([_issue_at(file, *scan.too_deep, _TOO_DEEP)])
        node = yaml.compose(text, Loader=yamltext.FAST_LOADER)
    except yaml.YAMLError as exc:
        raise ConfigError([_yaml_error(file, exc)]) from None
    if node is None:
        return Located(None, file, {(): Mark(file, 1, 1)})
    if scan.aliases:  # bound what the aliases expand to, before expanding anything
        at = scan.first_alias or (1, 1)
        total, distinct, height, recursive = yamltext.expansion(node)
        if recursive:
            raise ConfigError(
                [_issue_at(file, *at, "an alias (*name) refers to a value that contains it (a recursive alias)")]
            )
        if total - distinct > yamltext.MAX_ALIAS_EXPANSION:
            raise ConfigError(
                [
                    _issue_at(
                        file,
                        *at,
                        f"aliases (*name) expand the document by {total - distinct} values, "
                        f"more than {yamltext.MAX_ALIAS_EXPANSION} (an alias bomb?)",
                    )
                ]
            )
        if height > yamltext.MAX_DEPTH:
            raise ConfigError([_issue_at(file, *at, f"{_TOO_DEEP} (counting what the aliases repeat)")])
    builder = _Builder(file)
    try:
        data = builder.build(node, (), 1)
    except yaml.YAMLError as exc:
        raise ConfigError([_yaml_error(file, exc)]) from None
    if builder.issues:
        raise ConfigError(builder.issues)
    return Located(data, file, builder.marks, builder.key_marks, builder.bool_words)


def load_yaml(path: str | Path) -> Located:
    """Read and parse a YAML file. A missing, unreadable, too large or non-UTF-8
    file is a ConfigError too (see :mod:`maris_common.yamltext`)."""
    p = Path(path)
    try:
        size = p.stat().st_size
        too_big = yamltext.size_problem(size) if p.is_file() else None
        if too_big:
            raise ConfigError([_issue_at(str(p), 1, 1, too_big)])
        data = p.read_bytes()
    except (OSError, ValueError) as exc:
        raise ConfigError([_issue_at(str(p), 1, 1, f"cannot read file: {exc}")]) from None
    too_big = yamltext.size_problem(len(data))  # a pipe or a file that grew
    if too_big:
        raise ConfigError([_issue_at(str(p), 1, 1, too_big)])
    text, problems = yamltext.decode_utf8(data)
    if text is None:
        raise ConfigError([_issue_at(str(p), q.line, q.column, q.message) for q in problems])
    return parse_yaml(text, str(p))


#: Words people use for a name the formats call otherwise (world NED frame,
#: units in the names): checked before spelling similarity.
SYNONYMS = {
    "depth_m": "down_m",
    "depth": "down_m",
    "z_m": "down_m",
    "z": "down_m",
    "down": "down_m",
    "x_m": "north_m",
    "x": "north_m",
    "north": "north_m",
    "y_m": "east_m",
    "y": "east_m",
    "east": "east_m",
    "altitude": "altitude_m",
    "alt_m": "altitude_m",
    "height_m": "altitude_m",
    "heading_deg": "yaw_deg",
    "heading": "yaw_deg",
    "yaw": "yaw_deg",
    "psi_deg": "yaw_deg",
    "timeout": "timeout_s",
    "duration": "duration_s",
    "retries": "attempts",
    "tries": "attempts",
    "fallback": "selector",
    "wait_s": "duration_s",
    "goal": "vehicle_goal",
    "waypoint": "waypoints",
    "tolerance": "tolerance_m",
    "current_limit": "current_limit_a",
}


def suggest(word: str, choices: Iterable[str]) -> str:
    """`` (did you mean `x`?)`` for the closest choice, or an empty string.
    A known synonym (:data:`SYNONYMS`, e.g. ``depth_m`` -> ``down_m``) wins
    over spelling similarity."""
    choices = [str(c) for c in choices]
    alias = SYNONYMS.get(str(word)) or SYNONYMS.get(str(word).lower())
    if alias in choices:
        return f" (did you mean `{alias}`?)"
    best = difflib.get_close_matches(str(word), choices, n=1, cutoff=0.6)
    return f" (did you mean `{best[0]}`?)" if best else ""


def unknown_keys(src: Located, mapping: dict, path: PathT, allowed: Iterable[str]) -> list[ConfigIssue]:
    """Issues for keys of ``mapping`` (at ``path``) that are not in ``allowed``."""
    allowed = list(allowed)
    return [
        src.issue(path + (k,), f"unknown key `{k}`{suggest(k, allowed)}; allowed: {', '.join(sorted(allowed))}")
        for k in mapping
        if k not in allowed
    ]
