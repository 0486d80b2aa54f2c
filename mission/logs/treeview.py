"""Behaviour-tree snapshots drawn in py_trees' own text style.

A snapshot is the ``nodes`` list of a ``/tree`` message: pre-order
``{name, type, kind, status, depth, message}``. :func:`render_lines` draws it
the way ``py_trees.display.unicode_tree(root, show_status=True)`` draws a
live tree (``[-]`` sequence, ``{-}`` sequence with memory, ``[o]`` selector,
``/_/`` parallel, ``-^-`` decorator, ``-->`` leaf; status ``✓ ✕ * -``), so a
log replayed in the terminal looks like the tree the operator knows;
``colour=True`` adds ANSI colours (green success, red failure, yellow
running, grey not ticked). :func:`snapshot_at` and :func:`changes` pick
snapshots from a log for ``maris log tree``.
"""

from __future__ import annotations

from bisect import bisect_right
from collections.abc import Sequence
from typing import Any

from py_trees import composites, decorators
from py_trees import display as _display
from py_trees.common import Status

_SYMBOLS = _display.unicode_symbols
_KIND_SYMBOL = {
    "sequence": _SYMBOLS["sequence_without_memory"],
    "sequence_with_memory": _SYMBOLS["sequence_with_memory"],
    "selector": _SYMBOLS["selector_without_memory"],
    "selector_with_memory": _SYMBOLS["selector_with_memory"],
    "parallel": _SYMBOLS["parallel"],
    "decorator": _SYMBOLS["decorator"],
    "behaviour": _SYMBOLS["behaviour"],
}
_STATUS_SYMBOL = {s.value: _SYMBOLS[s] for s in Status}
_COLOURS = {"SUCCESS": "\x1b[32m", "FAILURE": "\x1b[31m", "RUNNING": "\x1b[33m", "INVALID": "\x1b[90m"}
_RESET = "\x1b[0m"


def node_kind(node: Any) -> str:
    """The display kind of a py_trees node (see :data:`_KIND_SYMBOL`)."""

    if isinstance(node, composites.Sequence):
        return "sequence_with_memory" if getattr(node, "memory", False) else "sequence"
    if isinstance(node, composites.Selector):
        return "selector_with_memory" if getattr(node, "memory", False) else "selector"
    if isinstance(node, composites.Parallel):
        return "parallel"
    if isinstance(node, decorators.Decorator):
        return "decorator"
    return "behaviour"


def render_lines(nodes: Sequence[dict], *, colour: bool = False) -> list[str]:
    """One line per node: indent (4 spaces per level), kind symbol, name, status
    symbol in brackets, `` -- message`` when the node has one."""
    lines = []
    for n in nodes:
        kind = n.get("kind") or ("behaviour" if not n.get("type") else _guess_kind(n["type"]))
        status = str(n.get("status", "INVALID"))
        mark = _STATUS_SYMBOL.get(status, "?")
        if colour:
            mark = f"{_COLOURS.get(status, '')}{mark}{_RESET}"
        text = f"{'    ' * int(n.get('depth', 0))}{_KIND_SYMBOL.get(kind, '-->')} {n.get('name', '?')} [{mark}]"
        if n.get("message"):
            text += f" -- {n['message']}"
        lines.append(text)
    return lines


def table_rows(nodes: Sequence[dict]) -> list[dict]:
    """:func:`render_lines` as ``[{"node": line}]`` rows for Foxglove's Table panel,
    indented with no-break spaces (a table cell would collapse plain ones)."""
    return [{"node": line.replace(" ", "\u00a0")} for line in render_lines(nodes)]


def _guess_kind(type_name: str) -> str:
    """Kind from a class name (logs written before ``kind`` was recorded)."""
    low = type_name.lower()
    for key in ("sequence", "selector", "parallel"):
        if key in low:
            return key
    return "behaviour"


def snapshot_at(snapshots: Sequence[dict], t: float) -> dict | None:
    """The last ``/tree`` message at or before backend time ``t`` (s), or None."""
    times = [float(m["t"]) for m in snapshots]
    i = bisect_right(times, t + 1e-9)
    return snapshots[i - 1] if i else None


def describe(snapshot: dict, t0: float = 0.0) -> str:
    """Header line of a snapshot: time since the run start, root status, running leaf."""
    tip = snapshot.get("tip") or "-"
    return f"t={float(snapshot['t']) - t0:8.2f} s  root {snapshot.get('root_status', '?')}  running leaf: {tip}"
