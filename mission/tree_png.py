"""Render a py_trees behaviour tree to a PNG with matplotlib (no Graphviz needed).

``maris show --png`` prefers Graphviz ``dot`` when it is installed; this is the
fallback so the command works on any machine the project installs on. Layout:
root on the left, one row per leaf, each composite centred on its children,
like the terminal rendering turned into boxes. Colours follow py_trees' dot
export: sequence orange, selector cyan, parallel gold, decorator white, leaf grey.
"""

from __future__ import annotations

import textwrap
from dataclasses import dataclass, field
from pathlib import Path

import py_trees

#: Box colours by node kind (the py_trees dot palette).
COLOURS = {"sequence": "orange", "selector": "cyan", "parallel": "gold", "decorator": "ghostwhite", "leaf": "gainsboro"}

#: Layout units: one leaf row (inches) and one tree level (inches).
ROW_IN, LEVEL_IN = 0.42, 2.6
LABEL_WIDTH_CHARS = 30


@dataclass
class PlacedNode:
    """A node and its place: ``depth`` (levels from the root), ``row`` (leaf rows, may be fractional)."""

    name: str
    kind: str
    depth: int
    row: float = 0.0
    children: list[PlacedNode] = field(default_factory=list)


def node_kind(behaviour: py_trees.behaviour.Behaviour) -> str:
    """``sequence``, ``selector``, ``parallel``, ``decorator`` or ``leaf``."""
    if isinstance(behaviour, py_trees.composites.Sequence):
        return "sequence"
    if isinstance(behaviour, py_trees.composites.Selector):
        return "selector"
    if isinstance(behaviour, py_trees.composites.Parallel):
        return "parallel"
    if isinstance(behaviour, py_trees.decorators.Decorator):
        return "decorator"
    return "leaf"


def place(root: py_trees.behaviour.Behaviour) -> tuple[PlacedNode, int]:
    """The placed tree and its number of leaf rows."""
    next_row = [0]

    def visit(b: py_trees.behaviour.Behaviour, depth: int) -> PlacedNode:  # depth is bounded (mission.structure)
        node = PlacedNode(b.name, node_kind(b), depth)
        node.children = [visit(c, depth + 1) for c in b.children]
        if node.children:
            node.row = 0.5 * (node.children[0].row + node.children[-1].row)
        else:
            node.row = float(next_row[0])
            next_row[0] += 1
        return node

    placed = visit(root, 0)
    return placed, next_row[0]


def _walk(node: PlacedNode):
    yield node
    for c in node.children:
        yield from _walk(c)


def write_tree_png(root: py_trees.behaviour.Behaviour, path: str | Path, title: str = "") -> None:
    """Draw ``root`` into the PNG file ``path``. Raises OSError if it cannot be written."""
    write_trees_png([("", root)], path, title)


def write_trees_png(trees: list[tuple[str, py_trees.behaviour.Behaviour]], path: str | Path, title: str = "") -> None:
    """Draw several trees (``(label, root)``, e.g. the main tree and the abort
    path) one below the other into the PNG file ``path``."""
    import matplotlib  # plotting only: matplotlib loads when a chart is drawn

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    placed_trees: list[tuple[str, list[PlacedNode], float]] = []
    offset = 0.0
    for label, root in trees:
        if label:
            offset += 1.0  # a row for the tree's label
        placed, rows = place(root)
        nodes = list(_walk(placed))
        for n in nodes:
            n.row += offset
        placed_trees.append((label, nodes, offset))
        offset += rows + 0.5
    all_nodes = [n for _, nodes, _ in placed_trees for n in nodes]
    depth = max(n.depth for n in all_nodes) + 1
    fig_w, fig_h = max(4.0, depth * LEVEL_IN), max(2.0, (offset + 1) * ROW_IN)
    fig, ax = plt.subplots(figsize=(fig_w, fig_h))
    try:
        ax.set_xlim(-0.6, depth - 0.4)
        ax.set_ylim(offset - 0.4, -0.8 if title else -0.6)
        ax.axis("off")
        for label, nodes, top in placed_trees:
            if label:
                ax.text(-0.4, top - 1.0, label, ha="left", va="center", fontsize=8, fontweight="bold")
            for n in nodes:
                for c in n.children:  # elbow connector: out of the parent, down, into the child
                    mid = n.depth + 0.5
                    ax.plot(
                        [n.depth + 0.05, mid, mid, c.depth - 0.45], [n.row, n.row, c.row, c.row], color="grey", lw=0.8
                    )
            for n in nodes:
                text = "\n".join(textwrap.wrap(n.name, LABEL_WIDTH_CHARS)) or "?"
                ax.text(
                    n.depth - 0.4,
                    n.row,
                    text,
                    ha="left",
                    va="center",
                    fontsize=7,
                    bbox={
                        "boxstyle": "round,pad=0.25" if n.kind == "leaf" else "square,pad=0.25",
                        "facecolor": COLOURS[n.kind],
                        "edgecolor": "black",
                        "linewidth": 0.6,
                    },
                )
        if title:
            ax.set_title(title, fontsize=9, loc="left")
        fig.savefig(path, dpi=110, bbox_inches="tight")
    finally:
        plt.close(fig)
