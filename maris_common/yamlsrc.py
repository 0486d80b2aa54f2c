"""YAML loading that remembers where every value came from.

All user-written files (missions, actions, scenarios, HAL configs) are read with
:func:`load_yaml`, so that any error can name ``file:line:column`` and the field.
Only ``yaml.SafeLoader`` is used: nothing in a file is ever executed.

Paths into the data are tuples of keys and list indices, e.g.
``("levels", 3, "gain")``; :func:`format_path` renders them as ``levels[3].gain``.
"""

from __future__ import annotations

import difflib
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Iterable, Sequence

import yaml

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
    """One problem in a file: where, which field, what is wrong."""

    mark: Mark
    path: PathT
    message: str

    def __str__(self) -> str:
        return f"{self.mark}: {format_path(self.path)}: {self.message}"


class ConfigError(Exception):
    """One or more problems in user-written files. ``str()`` lists them all,
    one per line, as ``file:line:column: field: message``."""

    def __init__(self, issues: Iterable[ConfigIssue]):
        self.issues: list[ConfigIssue] = list(issues)
        super().__init__("\n".join(str(i) for i in self.issues))


@dataclass
class Located:
    """Parsed YAML data plus the source mark of every node."""

    data: Any
    file: str
    marks: dict[PathT, Mark] = field(default_factory=dict)

    def mark(self, path: Sequence[Any]) -> Mark:
        """Mark of ``path``, or of its nearest ancestor that has one."""
        p = tuple(path)
        while p not in self.marks and p:
            p = p[:-1]
        return self.marks.get(p, Mark(self.file, 1, 1))

    def issue(self, path: Sequence[Any], message: str) -> ConfigIssue:
        return ConfigIssue(self.mark(path), tuple(path), message)


_PLAIN_COLLECTION_TAGS = ("tag:yaml.org,2002:map", "tag:yaml.org,2002:seq")


#: Largest number of nodes a document may expand to (aliases repeat nodes).
MAX_NODES = 200_000


class _TooLarge(Exception):
    pass


def _construct(node: yaml.Node, path: PathT, file: str, marks: dict[PathT, Mark], issues: list[ConfigIssue]) -> Any:
    if len(marks) > MAX_NODES:
        raise _TooLarge
    m = node.start_mark
    marks[path] = Mark(file, m.line + 1, m.column + 1)
    if isinstance(node, (yaml.MappingNode, yaml.SequenceNode)) and node.tag not in _PLAIN_COLLECTION_TAGS:
        issues.append(ConfigIssue(marks[path], path, f"unsupported YAML tag {node.tag!r}: only plain mappings, lists and scalars are allowed"))
        return None
    if isinstance(node, yaml.MappingNode):
        out: dict[Any, Any] = {}
        for key_node, value_node in node.value:
            key = yaml.SafeLoader(" ").construct_object(key_node, deep=True) if not isinstance(key_node, yaml.ScalarNode) else _scalar(key_node)
            km = key_node.start_mark
            if not isinstance(key, (str, int, float, bool)):
                issues.append(ConfigIssue(Mark(file, km.line + 1, km.column + 1), path, f"unsupported key {key!r}"))
                continue
            if key in out:
                issues.append(ConfigIssue(Mark(file, km.line + 1, km.column + 1), path + (key,), "duplicate key (the later value would silently win)"))
                continue
            out[key] = _construct(value_node, path + (key,), file, marks, issues)
        return out
    if isinstance(node, yaml.SequenceNode):
        return [_construct(v, path + (i,), file, marks, issues) for i, v in enumerate(node.value)]
    return _scalar(node)


def _scalar(node: yaml.Node) -> Any:
    loader = yaml.SafeLoader("")
    return loader.construct_object(node, deep=True)


def parse_yaml(text: str, file: str = "<string>") -> Located:
    """Parse YAML text (safe loader only), recording a mark for every node.

    Raises :class:`ConfigError` for syntax errors, duplicate keys and unsupported
    constructs (tags that would build Python objects are rejected by SafeLoader).
    """
    try:
        node = yaml.compose(text, Loader=yaml.SafeLoader)
    except yaml.MarkedYAMLError as exc:
        m = exc.problem_mark or exc.context_mark
        mark = Mark(file, m.line + 1, m.column + 1) if m else Mark(file, 1, 1)
        raise ConfigError([ConfigIssue(mark, (), f"YAML syntax error: {exc.problem or exc}")]) from None
    except yaml.YAMLError as exc:
        raise ConfigError([ConfigIssue(Mark(file, 1, 1), (), f"YAML error: {exc}")]) from None
    if node is None:
        return Located(None, file, {(): Mark(file, 1, 1)})
    marks: dict[PathT, Mark] = {}
    issues: list[ConfigIssue] = []
    try:
        data = _construct(node, (), file, marks, issues)
    except _TooLarge:
        raise ConfigError([ConfigIssue(Mark(file, 1, 1), (), f"document expands to more than {MAX_NODES} values (alias bomb?)")]) from None
    except RecursionError:
        raise ConfigError([ConfigIssue(Mark(file, 1, 1), (), "document is nested too deeply (recursive alias?)")]) from None
    except yaml.constructor.ConstructorError as exc:
        m = exc.problem_mark
        mark = Mark(file, m.line + 1, m.column + 1) if m else Mark(file, 1, 1)
        raise ConfigError([ConfigIssue(mark, (), f"unsupported YAML: {exc.problem}")]) from None
    if issues:
        raise ConfigError(issues)
    return Located(data, file, marks)


def load_yaml(path: str | Path) -> Located:
    """Read and parse a YAML file; a missing/unreadable file is a ConfigError too."""
    p = Path(path)
    try:
        text = p.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        raise ConfigError([ConfigIssue(Mark(str(p), 1, 1), (), f"cannot read file: {exc}")]) from None
    return parse_yaml(text, str(p))


def suggest(word: str, choices: Iterable[str]) -> str:
    """`` (did you mean `x`?)`` for the closest choice, or an empty string."""
    best = difflib.get_close_matches(str(word), [str(c) for c in choices], n=1, cutoff=0.6)
    return f" (did you mean `{best[0]}`?)" if best else ""


def unknown_keys(src: Located, mapping: dict, path: PathT, allowed: Iterable[str]) -> list[ConfigIssue]:
    """Issues for keys of ``mapping`` (at ``path``) that are not in ``allowed``."""
    allowed = list(allowed)
    return [
        src.issue(path + (k,), f"unknown key `{k}`{suggest(k, allowed)}; allowed: {', '.join(sorted(allowed))}")
        for k in mapping
        if k not in allowed
    ]
