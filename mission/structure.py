"""The shape of a mission's trees once subtrees are expanded: cycles, nesting
depth, size, and which subtrees are used.

A ``subtree`` leaf is compiled into a decorator over a fresh copy of the
subtree's body, so a chain of subtrees nests as deep as all their bodies
together and a subtree used twice counts twice. These limits keep every
later step (compiling, displaying, ticking, logging) bounded and free of
Python recursion limits, whatever the file:

* :data:`MAX_TREE_DEPTH`: levels of nodes from the root to the deepest leaf;
* :data:`MAX_TREE_NODES`: nodes of one compiled tree (main tree, abort tree).

Every function here is iterative over subtree references (a chain of a
thousand subtrees is fine) and linear in the file's size: each subtree body is
measured once.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field

from .schema import Reader
from .spec import Node

#: Deepest nesting of one tree, counting the nodes of the subtrees it uses.
MAX_TREE_DEPTH = 40
#: Most nodes in one compiled tree (each use of a subtree counts its nodes again).
MAX_TREE_NODES = 10_000


def subtree_refs(node: Node) -> list[Node]:
    """The ``subtree`` leaves under ``node`` (not expanded), in file order."""
    return [n for n in node.walk() if n.kind == "subtree"]


@dataclass
class SubtreeGraph:
    """Which subtree uses which; ``order`` lists the acyclic ones so that a
    subtree comes after every subtree it uses; ``cyclic`` are on a cycle."""

    refs: dict[str, list[Node]]
    order: list[str] = field(default_factory=list)
    cyclic: set[str] = field(default_factory=set)


def subtree_graph(r: Reader, subtrees: Mapping[str, Node]) -> SubtreeGraph:
    """Depth-first search without recursion; records one issue per cycle found."""
    g = SubtreeGraph({name: subtree_refs(body) for name, body in subtrees.items()})
    state: dict[str, int] = {}  # 1 = on the stack, 2 = done
    for start in subtrees:
        if start in state:
            continue
        stack: list[tuple[str, int]] = [(start, 0)]
        state[start] = 1
        while stack:
            name, i = stack[-1]
            refs = g.refs[name]
            if i == len(refs):
                stack.pop()
                state[name] = 2
                g.order.append(name)
                continue
            stack[-1] = (name, i + 1)
            ref = refs[i]
            target = ref.use
            if target not in g.refs:
                continue
            if state.get(target) == 1:
                names = [n for n, _ in stack]
                loop = names[names.index(target) :]
                g.cyclic.update(loop)
                r.error(ref.path + ("use",), f"subtree cycle: {' -> '.join(loop + [target])}")
            elif target not in state:
                state[target] = 1
                stack.append((target, 0))
    g.order = [n for n in g.order if n not in g.cyclic]
    return g


@dataclass
class Measure:
    """Expanded height (levels) and node count of each subtree, both capped just
    past their limits so that pathological files stay cheap."""

    height: dict[str, int] = field(default_factory=dict)
    size: dict[str, int] = field(default_factory=dict)

    def node(self, node: Node) -> tuple[int, int]:
        """(height, size) of ``node`` with subtrees expanded (unknown or cyclic
        subtrees count as a leaf)."""
        if node.kind == "subtree":
            use = node.use
            return 1 + self.height.get(use, 0), 1 + self.size.get(use, 0)
        h, n = 0, 0
        for child in node.children:
            ch, cn = self.node(child)
            h, n = max(h, ch), n + cn
        return min(1 + h, MAX_TREE_DEPTH + 1), min(1 + n, MAX_TREE_NODES + 1)


def measure(subtrees: Mapping[str, Node], graph: SubtreeGraph) -> Measure:
    m = Measure()
    for name in graph.order:  # dependencies first
        m.height[name], m.size[name] = m.node(subtrees[name])
    return m


def _deepest_path(node: Node, m: Measure, subtrees: Mapping[str, Node]) -> tuple[Node, list[str]]:
    """The node at depth ``MAX_TREE_DEPTH + 1`` on a deepest path, and the
    subtrees entered on the way."""
    chain: list[str] = []
    depth = 1
    while depth <= MAX_TREE_DEPTH:
        if node.kind == "subtree":
            use = node.use
            chain.append(use)
            node = subtrees[use]
        else:
            node = max(node.children, key=lambda c: m.node(c)[0])
        depth += 1
    return node, chain


def _chain_text(root: str, chain: list[str]) -> str:
    names = [root] + chain
    if len(names) > 8:
        names = names[:4] + [f"... ({len(names) - 6} more)"] + names[-2:]
    return " -> ".join(names)


def check_structure(r: Reader, roots: Iterable[tuple[str, Node]], subtrees: Mapping[str, Node]) -> SubtreeGraph:
    """Cycles, depth and size of each root (``(section, node)``); issues on ``r``."""
    graph = subtree_graph(r, subtrees)
    m = measure(subtrees, graph)
    for section, root in roots:
        height, size = m.node(root)
        if height > MAX_TREE_DEPTH:
            node, chain = _deepest_path(root, m, subtrees)
            via = f" (through subtrees {_chain_text(section, chain)})" if chain else ""
            r.error(
                node.path,
                f"the `{section}` tree nests deeper than {MAX_TREE_DEPTH} levels here{via}; "
                f"the limit is {MAX_TREE_DEPTH}: flatten it (sequences of sequences can be merged)",
            )
        elif size > MAX_TREE_NODES:
            r.error(
                root.path,
                f"the `{section}` tree expands to more than {MAX_TREE_NODES} nodes (a subtree counts again "
                f"at each use); the limit is {MAX_TREE_NODES}",
            )
    return graph


def used_subtrees(roots: Iterable[Node], graph: SubtreeGraph) -> set[str]:
    """Names of the subtrees reachable from ``roots``."""
    todo = [ref.use for root in roots for ref in subtree_refs(root)]
    seen: set[str] = set()
    while todo:
        name = todo.pop()
        if name in seen or name not in graph.refs:
            continue
        seen.add(name)
        todo.extend(ref.use for ref in graph.refs[name])
    return seen
