"""Checks on YAML input *before* it is built into Python values.

Everything here bounds the work a file can cause and names the exact place of
a problem (1-based line and column), so that no input ever ends in a traceback
or a misleading message:

* :data:`MAX_FILE_BYTES`: a file larger than this is refused at once, with
  its size, before it is read;
* :func:`decode_utf8`: invalid UTF-8 is reported at the line and column of
  the first bad bytes (a UTF-16 byte-order mark gets its own hint);
* :func:`bad_characters`: NUL bytes and other control characters, which YAML
  forbids, are reported where they are;
* :func:`scan_events`: one pass over the parser's events (iterative, no
  recursion) measures the nesting depth (limit :data:`MAX_DEPTH`, reported at
  the first node past it) and counts the aliases (``*name``), so that the
  expansion limit is applied only to documents that have aliases.
"""

from __future__ import annotations

import re
from dataclasses import dataclass

import yaml

#: Largest YAML input file, bytes. A mission with 10,000 waypoints is about 0.6 MB.
MAX_FILE_BYTES = 2_000_000
#: Deepest nesting of mappings and lists in one document. A mission tree nests
#: 3 levels per composite node; its own limit (mission.checks.MAX_TREE_DEPTH)
#: is reached well before this one.
MAX_DEPTH = 128
#: Most values that aliases (``*name``) may add to a document by repeating
#: anchored values ("billion laughs" protection). Only counted when the
#: document has aliases: the work of a document without them is bounded by its size.
MAX_ALIAS_EXPANSION = 100_000

#: The loader class used for parsing: LibYAML's when PyYAML has it (about 10x
#: faster), else the pure-Python one. Both are safe loaders.
FAST_LOADER = getattr(yaml, "CSafeLoader", yaml.SafeLoader)

# Characters YAML 1.1 does not allow in a stream (PyYAML's own rule).
_NON_PRINTABLE = re.compile("[^\x09\x0a\x0d\x20-\x7e\x85\xa0-\ud7ff\ue000-\ufffd\U00010000-\U0010ffff]")
#: Problems of one kind reported per file, at most (the first ones).
MAX_REPORTED = 5


@dataclass(frozen=True)
class TextProblem:
    """A problem at a 1-based ``line`` and ``column`` of the text."""

    line: int
    column: int
    message: str


def line_column(text: str, index: int) -> tuple[int, int]:
    """1-based line and column of character ``index`` in ``text``."""
    line = text.count("\n", 0, index) + 1
    return line, index - (text.rfind("\n", 0, index) + 1) + 1


def size_problem(size: int) -> str | None:
    """Why a file of ``size`` bytes is refused, or None."""
    if size <= MAX_FILE_BYTES:
        return None
    return (
        f"file is {size / 1e6:.2f} MB, larger than the {MAX_FILE_BYTES / 1e6:g} MB limit for YAML input files "
        f"(a mission with 10,000 waypoints is about 0.6 MB)"
    )


def decode_utf8(data: bytes) -> tuple[str | None, list[TextProblem]]:
    """``data`` as text, or None and where it is not valid UTF-8."""
    try:
        return data.decode("utf-8"), []
    except UnicodeDecodeError:
        pass
    if data[:2] in (b"\xff\xfe", b"\xfe\xff"):
        return None, [TextProblem(1, 1, "file is not UTF-8: it starts with a UTF-16 byte-order mark; save it as UTF-8")]
    problems: list[TextProblem] = []
    pos = 0
    while len(problems) < MAX_REPORTED:
        try:
            data[pos:].decode("utf-8")
            break
        except UnicodeDecodeError as exc:
            start, end = pos + exc.start, pos + exc.end
        line_start = data.rfind(b"\n", 0, start) + 1
        line = data.count(b"\n", 0, start) + 1
        column = len(data[line_start:start].decode("utf-8", "replace")) + 1
        shown = " ".join(f"0x{b:02x}" for b in data[start:end])
        problems.append(TextProblem(line, column, f"not valid UTF-8 (byte {shown}); save the file as UTF-8"))
        pos = end
    return None, problems


def bad_characters(text: str) -> list[TextProblem]:
    """Positions of characters YAML does not allow (NUL, other control characters)."""
    problems = []
    for m in _NON_PRINTABLE.finditer(text):
        ch = m.group()
        line, column = line_column(text, m.start())
        what = "a NUL byte (U+0000)" if ch == "\0" else f"control character U+{ord(ch):04X}"
        problems.append(
            TextProblem(line, column, f"{what} is not allowed in YAML (only tab, newline and carriage return)")
        )
        if len(problems) >= MAX_REPORTED:
            break
    return problems


@dataclass(frozen=True)
class Scan:
    """What :func:`scan_events` found: the alias count, the first alias's place
    and, if the document nests too deeply, where."""

    aliases: int
    first_alias: tuple[int, int] | None
    too_deep: tuple[int, int] | None


def scan_events(text: str) -> Scan:
    """One pass over the parse events. Raises the parser's ``yaml.YAMLError``
    on syntax errors (the caller reports them with their mark)."""
    depth = 0
    aliases = 0
    first_alias = None
    for ev in yaml.parse(text, Loader=FAST_LOADER):
        if isinstance(ev, (yaml.MappingStartEvent, yaml.SequenceStartEvent)):
            depth += 1
            if depth > MAX_DEPTH:
                m = ev.start_mark
                return Scan(aliases, first_alias, (m.line + 1, m.column + 1))
        elif isinstance(ev, (yaml.MappingEndEvent, yaml.SequenceEndEvent)):
            depth -= 1
        elif isinstance(ev, yaml.AliasEvent):
            aliases += 1
            if first_alias is None:
                first_alias = (ev.start_mark.line + 1, ev.start_mark.column + 1)
    return Scan(aliases, first_alias, None)


def expansion(root: yaml.Node) -> tuple[int, int, int, bool]:
    """For a composed document with aliases: ``(values once expanded, distinct
    values, expanded depth, recursive)``, without expanding anything (each
    distinct node is visited once; iterative). ``recursive``: an alias refers
    to a node that contains it (the counts are then meaningless)."""
    size: dict[int, int] = {}
    height: dict[int, int] = {}
    on_stack: set[int] = set()
    stack: list[tuple[yaml.Node, bool]] = [(root, False)]
    while stack:
        node, done = stack.pop()
        key = id(node)
        if done:
            kids = _children(node)
            size[key] = 1 + sum(size[id(k)] for k in kids)
            height[key] = 1 + max((height[id(k)] for k in kids), default=0)
            on_stack.discard(key)
            continue
        if key in size:
            continue
        if key in on_stack:
            return 0, 0, 0, True
        on_stack.add(key)
        stack.append((node, True))
        for k in _children(node):
            if id(k) in on_stack:
                return 0, 0, 0, True
            if id(k) not in size:
                stack.append((k, False))
    return size[id(root)], len(size), height[id(root)], False


def _children(node: yaml.Node) -> list[yaml.Node]:
    if isinstance(node, yaml.MappingNode):
        return [n for pair in node.value for n in pair]
    if isinstance(node, yaml.SequenceNode):
        return list(node.value)
    return []
