"""Small typed readers over located YAML data that collect every problem.

A :class:`Reader` wraps one :class:`maris_common.yamlsrc.Located` document.
Its methods read one field each (number with range, bool, string, choice,
list of numbers) and, instead of raising, append a
:class:`~maris_common.yamlsrc.ConfigIssue` naming ``file:line:column`` and the
field path, then return a fallback value so checking goes on. The loader
raises one :class:`~maris_common.yamlsrc.ConfigError` with all issues at the end.

Positions: issues about a value point at the value; issues about a key itself
(unknown key, unknown node kind) point at the key (:meth:`Reader.key_error`).
"""

from __future__ import annotations

import math
import re
from collections.abc import Iterable, Sequence
from typing import Any

from maris_common.yamlsrc import ConfigIssue, Located, Mark, suggest

from .format import REQUIRED

MISSING = object()


def type_name(value: Any) -> str:
    """Readable YAML-ish name of a value's type, for messages."""
    if value is None:
        return "null"
    if isinstance(value, bool):
        return "a boolean"
    if isinstance(value, (int, float)):
        return "a number"
    if isinstance(value, str):
        return "a string"
    if isinstance(value, list):
        return "a list"
    if isinstance(value, dict):
        return "a mapping"
    return type(value).__name__


def is_number(value: Any) -> bool:
    """True for int/float values that are not booleans and are finite."""
    return isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value)


_EXPONENT_NUMBER = re.compile(r"^[-+]?(\d[\d_]*\.?\d*|\.\d+)[eE][-+]?\d+$")


def _looks_numeric(text: str) -> bool:
    """A number YAML 1.2 would read but YAML 1.1 (PyYAML) keeps as text, e.g. ``1e3``."""
    return bool(_EXPONENT_NUMBER.match(text.strip()))


class Reader:
    """Reads fields from one located document, collecting issues.

    text: the document's text, for :meth:`key_error` (read again from
    ``src.file`` when not given).
    """

    def __init__(self, src: Located, text: str | None = None):
        self.src = src
        self.issues: list[ConfigIssue] = []
        #: Findings that do not stop the mission from loading (see mission.lint).
        self.warnings: list[ConfigIssue] = []
        #: Names (blackboard keys, subtrees) whose declaration had errors: their
        #: uses are not reported again as undeclared.
        self.broken: set[tuple[str, str]] = set()  # ("blackboard" | "subtree", name)

    # ------------------------------------------------------------------ basics
    def mark(self, path: Sequence[Any]) -> Mark:
        return self.src.mark(path)

    def error(self, path: Sequence[Any], message: str) -> None:
        issue = self.src.issue(path, message)
        if issue not in self.issues:
            self.issues.append(issue)

    def key_error(self, path: Sequence[Any], message: str) -> None:
        """Like :meth:`error`, positioned at the key of ``path`` (e.g. an unknown key)."""
        issue = ConfigIssue(self.src.key_mark(path), tuple(path), message)
        if issue not in self.issues:
            self.issues.append(issue)

    def warn(self, path: Sequence[Any], message: str, *, at_key: bool = False) -> None:
        """Record a warning (the mission still loads; ``--strict`` refuses it)."""
        mark = self.src.key_mark(path) if at_key else self.mark(path)
        issue = ConfigIssue(mark, tuple(path), message, "warning")
        if issue not in self.warnings:
            self.warnings.append(issue)

    def has_issue_under(self, path: Sequence[Any]) -> bool:
        """Whether an error was already recorded at ``path`` or below it."""
        p = tuple(path)
        return any(i.path[: len(p)] == p for i in self.issues)

    def got(self, path: Sequence[Any], value: Any) -> str:
        """``a string 'x'``-style text of a wrong value, saying so when YAML 1.1
        turned a bare word (``on``, ``off``, ``yes``, ``no``) into a boolean."""
        word = self.src.bool_words.get(tuple(path)) if isinstance(value, bool) else None
        if word is not None:
            return (
                f"`{word}`, which YAML reads as the boolean {str(value).lower()} "
                f"(write '{word}' in quotes if you mean the word)"
            )
        if isinstance(value, str) and _looks_numeric(value):
            return (
                f"the text '{value}': YAML 1.1 reads a number with an exponent as a number only with a "
                f"decimal point and a signed exponent (e.g. 1.0e+3, not 1e3)"
            )
        return f"{type_name(value)} {value!r}"

    def mapping(self, value: Any, path: tuple, what: str = "a mapping") -> dict | None:
        """``value`` if it is a mapping, else record an issue and return None."""
        if isinstance(value, dict):
            return value
        self.error(path, f"expected {what}, got {type_name(value)}")
        return None

    def check_keys(self, mapping: dict, path: tuple, allowed: Iterable[str]) -> None:
        """Record an issue for each key not in ``allowed`` (with a suggestion)."""
        allowed = list(allowed)
        for key in mapping:
            if key not in allowed:
                self.key_error(
                    path + (key,),
                    f"unknown key `{key}`{suggest(str(key), allowed)}; allowed: {', '.join(sorted(allowed))}",
                )

    # ------------------------------------------------------------------ fields
    def field(self, m: dict, path: tuple, f: Any) -> Any:
        """Read the scalar field described by ``f`` (a :class:`mission.format.Field`
        of type number, integer, bool, string or choice) from mapping ``m``."""

        default = MISSING if f.default is REQUIRED else f.default
        if f.nullable and m.get(f.name, 0) is None:
            return None
        if f.type in ("number", "integer"):
            return self.number(
                m, path, f.name, default=default, lo=f.lo, hi=f.hi, lo_open=f.lo_open, integer=f.type == "integer"
            )
        if f.type == "bool":
            return self.boolean(m, path, f.name, f.default)
        if f.type == "string":
            return self.string(m, path, f.name, default=default)
        if f.type == "choice":
            return self.choice(m, path, f.name, f.choices, default=default)
        if f.type == "choices":
            return self.choices(m, path, f.name, f.choices, default=default)
        raise TypeError(f"field {f.name!r} of type {f.type!r} is not a scalar field")

    def number(
        self,
        m: dict,
        path: tuple,
        key: str,
        *,
        default: Any = MISSING,
        lo: float | None = None,
        hi: float | None = None,
        lo_open: bool = False,
        integer: bool = False,
    ) -> Any:
        """Numeric field ``m[key]``; ``default`` MISSING means required.

        ``lo``/``hi`` are inclusive bounds (``lo_open`` makes ``lo`` exclusive).
        Returns the default (or None) on error.
        """
        if self._absent(m, path, key, default):
            return None if default is MISSING else default
        value = m[key]
        fpath = path + (key,)
        if value is None and default is not MISSING and default is None:
            return None
        if integer:
            if is_number(value) and float(value).is_integer():  # 3.0 is the integer 3 (as in JSON Schema)
                value = int(value)
            if not (isinstance(value, int) and not isinstance(value, bool)):
                self.error(fpath, f"expected an integer, got {self.got(fpath, value)}")
                return None if default is MISSING else default
        elif not is_number(value):
            self.error(fpath, f"expected a finite number, got {self.got(fpath, value)}")
            return None if default is MISSING else default
        if lo is not None and (value < lo or (lo_open and value == lo)):
            bound = f"> {lo}" if lo_open else f">= {lo}"
            self.error(fpath, f"{value} is out of range: must be {bound}")
            return None if default is MISSING else default
        if hi is not None and value > hi:
            self.error(fpath, f"{value} is out of range: must be <= {hi}")
            return None if default is MISSING else default
        return int(value) if integer else float(value)

    def _absent(self, m: dict, path: tuple, key: str, default: Any) -> bool:
        """Whether ``key`` is missing from ``m``; an error when it is required (``default`` MISSING)."""
        if key in m:
            return False
        if default is MISSING:
            self.error(path + (key,), f"missing required field `{key}`")
        return True

    def boolean(self, m: dict, path: tuple, key: str, default: bool) -> bool:
        if key not in m:
            return default
        value = m[key]
        if not isinstance(value, bool):
            self.error(path + (key,), f"expected true or false, got {self.got(path + (key,), value)}")
            return default
        return value

    def string(self, m: dict, path: tuple, key: str, *, default: Any = MISSING) -> Any:
        if self._absent(m, path, key, default):
            return None if default is MISSING else default
        value = m[key]
        if value is None and default is None:
            return None
        if not isinstance(value, str) or not value.strip():
            self.error(path + (key,), f"expected a non-empty string, got {self.got(path + (key,), value)}")
            return None if default is MISSING else default
        return value

    def choice(self, m: dict, path: tuple, key: str, choices: Sequence[str], *, default: Any = MISSING) -> Any:
        if key not in m:
            return self.string(m, path, key, default=default)
        value = self.string(m, path, key, default=default)
        if value is None:
            return None if default is MISSING else default
        if value not in choices:
            self.error(
                path + (key,),
                f"unknown value `{value}`{suggest(value, choices)}; expected one of: {', '.join(choices)}",
            )
            return None if default is MISSING else default
        return value

    def choices(self, m: dict, path: tuple, key: str, choices: Sequence[str], *, default: Any = MISSING) -> Any:
        """A non-empty list of distinct values among ``choices`` (as a tuple)."""
        if self._absent(m, path, key, default):
            return None if default is MISSING else default
        value = m[key]
        if not isinstance(value, list) or not value:
            self.error(path + (key,), f"expected a non-empty list of: {', '.join(choices)}; got {type_name(value)}")
            return None if default is MISSING else default
        out: list[str] = []
        for i, item in enumerate(value):
            if not isinstance(item, str) or item not in choices:
                hint = suggest(item, choices) if isinstance(item, str) else ""
                self.error(path + (key, i), f"unknown value `{item}`{hint}; expected one of: {', '.join(choices)}")
            elif item in out:
                self.error(path + (key, i), f"`{item}` is listed twice")
            else:
                out.append(item)
        return tuple(out) if out else (None if default is MISSING else default)

    def interval(self, m: dict, path: tuple, key: str) -> tuple[float, float] | None:
        """Required ``[low, high]`` pair of numbers with low < high."""
        if key not in m:
            self.error(path + (key,), f"missing required field `{key}` ([low, high])")
            return None
        value = m[key]
        fpath = path + (key,)
        if not (isinstance(value, list) and len(value) == 2 and all(is_number(v) for v in value)):
            self.error(fpath, f"expected [low, high] (two numbers), got {value!r}")
            return None
        lo, hi = float(value[0]), float(value[1])
        if not lo < hi:
            self.error(fpath, f"low bound {lo} must be below high bound {hi}")
            return None
        return lo, hi
