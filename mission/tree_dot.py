"""Graphviz DOT text of a mission's compiled trees (``maris show --dot/--png``).

Written here rather than with py_trees' exporter: node names are free text
(``Log: pipe grasped``, quotes, backslashes), so every identifier is a
generated ``m0``, ``a3``... and every name goes into a quoted, escaped label;
the main tree and the abort path are two clusters of one graph, with no
made-up root joining them. Shapes and colours follow py_trees' own export
(sequence orange box, selector cyan octagon, parallel gold parallelogram,
decorator white ellipse, leaf grey ellipse).
"""

from __future__ import annotations

from collections.abc import Iterable

import py_trees

from mission.tree_png import node_kind

_STYLE = {
    "sequence": ("box", "orange"),
    "selector": ("octagon", "cyan"),
    "parallel": ("parallelogram", "gold"),
    "decorator": ("ellipse", "ghostwhite"),
    "leaf": ("ellipse", "gainsboro"),
}


def quote(text: str) -> str:
    """``text`` as a DOT quoted string: backslashes and quotes escaped, line
    breaks as ``\\n`` (so no Graphviz escape such as ``\\N`` can sneak in)."""
    body = str(text).replace("\\", "\\\\").replace('"', '\\"')
    body = body.replace("\r\n", "\n").replace("\r", "\n").replace("\n", "\\n")
    return f'"{body}"'


def _walk(root: py_trees.behaviour.Behaviour) -> Iterable[tuple[py_trees.behaviour.Behaviour, int | None]]:
    """(behaviour, parent index) in depth-first order; iterative."""
    stack: list[tuple[py_trees.behaviour.Behaviour, int | None]] = [(root, None)]
    index = 0
    while stack:
        b, parent = stack.pop()
        yield b, parent
        me = index
        index += 1
        stack.extend((c, me) for c in reversed(b.children))


def to_dot(trees: list[tuple[str, py_trees.behaviour.Behaviour]], title: str = "") -> str:
    """One ``digraph`` with a cluster per ``(label, root)`` tree."""
    lines = [
        f"digraph {quote(title or 'mission')} {{",
        '  graph [fontname="sans-serif", ordering=out, rankdir=TB];',
        '  node [fontname="sans-serif", fontsize=11, style=filled];',
        "  edge [arrowsize=0.6];",
    ]
    if title:
        lines.append(f"  label={quote(title)}; labelloc=t;")
    edges: list[str] = []
    for t, (label, root) in enumerate(trees):
        prefix = f"t{t}n"
        lines.append(f"  subgraph {quote('cluster_' + str(t))} {{")
        lines.append(f"    label={quote(label)};")
        for i, (b, parent) in enumerate(_walk(root)):
            shape, colour = _STYLE[node_kind(b)]
            lines.append(f"    {prefix}{i} [label={quote(b.name)}, shape={shape}, fillcolor={colour}];")
            if parent is not None:
                edges.append(f"  {prefix}{parent} -> {prefix}{i};")
        lines.append("  }")
    lines.extend(edges)
    lines.append("}")
    return "\n".join(lines) + "\n"
