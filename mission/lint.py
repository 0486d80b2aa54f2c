"""The safety lint: what a mission does that is legal but unsafe or pointless.

Errors (the mission is refused):

* an ``action`` or ``teleop`` leaf that is not bounded: no ``timeout_s`` of its
  own and no enclosing ``timeout`` or ``guard`` (through subtree uses too).

Warnings (the mission loads; ``maris validate --strict`` refuses it):

* a goal (``vehicle_goal``, a waypoint) outside the geofence, deeper than
  ``max_depth_m``, or an ``altitude_m`` goal below ``min_altitude_m``:
  reaching it breaches the envelope and aborts the mission;
* a time limit (``timeout_s``, ``duration_s``) longer than the whole mission
  (``max_duration_s``): it can never fire;
* a subtree that no tree uses;
* a child that can never run: after a child that always succeeds in a
  ``selector``, after a child that always fails in a ``sequence``.

``docs/missions.md`` lists the same rules for operators.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from typing import NamedTuple

from .schema import Reader
from .spec import Node, Safety
from .structure import SubtreeGraph, used_subtrees

# --------------------------------------------------------------------------- bounded actions


def check_bounded(r: Reader, roots: Iterable[Node], subtrees: Mapping[str, Node]) -> None:
    """Every action reachable from ``roots`` is bounded. Each subtree body is
    visited at most twice (bounded or not by its user), without recursion."""
    seen: set[tuple[str, bool]] = set()
    todo: list[tuple[Node, bool, tuple[str, ...]]] = [(root, False, ()) for root in roots]
    while todo:
        node, bounded, chain = todo.pop()
        if node.kind in ("timeout", "guard"):
            bounded = True
        if node.kind in ("action", "teleop") and not bounded and node.params.get("timeout_s") is None:
            if not r.has_issue_under(node.path + ("timeout_s",)):  # a bad timeout_s was reported already
                where = f" (used from subtree chain {' -> '.join(chain)})" if chain else ""
                what = f"action `{node.params.get('run')}`" if node.kind == "action" else "teleop (operator control)"
                r.error(
                    node.path,
                    f"{what} is not bounded: give it `timeout_s`, or put it inside a `timeout` or `guard`{where}",
                )
        if node.kind == "subtree":
            use = node.use
            if use in subtrees and (use, bounded) not in seen:
                seen.add((use, bounded))
                todo.append((subtrees[use], bounded, chain + (use,)))
        todo.extend((child, bounded, chain) for child in reversed(node.children))


# --------------------------------------------------------------------------- warnings


def _goals(node: Node) -> list[tuple[tuple, dict]]:
    t = node.params.get("targets") or {}
    path = node.path + ("targets",)
    if t.get("vehicle_goal"):
        return [(path + ("vehicle_goal",), t["vehicle_goal"])]
    return [(path + ("waypoints", i), g) for i, g in enumerate(t.get("waypoints") or [])]


def _check_goals(r: Reader, node: Node, safety: Safety) -> None:
    fence = safety.geofence
    for gpath, goal in _goals(node):
        what = "waypoint" if "waypoints" in gpath else "vehicle goal"
        for axis, bounds in (("north_m", fence.north_m), ("east_m", fence.east_m), ("down_m", fence.down_m)):
            v = goal.get(axis)
            if v is None:
                continue
            if axis == "down_m" and v > safety.max_depth_m:
                r.warn(
                    gpath + (axis,),
                    f"{what} at depth {v:g} m is deeper than safety.max_depth_m {safety.max_depth_m:g} m: "
                    "reaching it breaches the envelope and aborts the mission",
                )
            elif not bounds[0] <= v <= bounds[1]:
                r.warn(
                    gpath + (axis,),
                    f"{what} {axis} {v:g} m is outside the geofence ({axis} {bounds[0]:g}..{bounds[1]:g} m): "
                    "reaching it breaches the envelope and aborts the mission",
                )
        alt = goal.get("altitude_m")
        if alt is not None and alt < safety.min_altitude_m:
            r.warn(
                gpath + ("altitude_m",),
                f"{what} at altitude {alt:g} m is below safety.min_altitude_m "
                f"{safety.min_altitude_m:g} m: reaching it breaches the envelope and aborts the mission",
            )


_TIME_LIMITS = {
    "action": "timeout_s",
    "gripper": "timeout_s",
    "teleop": "timeout_s",
    "timeout": "duration_s",
    "wait": "duration_s",
}


def _check_time(r: Reader, node: Node, safety: Safety) -> None:
    key = _TIME_LIMITS.get(node.kind)
    value = node.params.get(key) if key else None
    if value is not None and value > safety.max_duration_s:
        what = "waits" if node.kind == "wait" else "is a time limit that can never fire"
        r.warn(
            node.path + (key,),
            f"{key} {value:g} s is longer than the whole mission (safety.max_duration_s "
            f"{safety.max_duration_s:g} s): it {what}; the mission's duration limit aborts first",
        )


class Outcome(NamedTuple):
    """Whether a subtree can only ever succeed, or only ever fail (False when unsure)."""

    succeeds: bool
    fails: bool


#: A subtree the mission does not define: judged neither way.
UNKNOWN = Outcome(False, False)


class Outcomes:
    """Which nodes can only ever succeed, or only ever fail (conservative:
    False when unsure). Subtrees are judged once each, dependencies first."""

    def __init__(self, subtrees: Mapping[str, Node], graph: SubtreeGraph) -> None:
        self._sub: dict[str, Outcome] = {}
        for name in graph.order:
            body = subtrees[name]
            self._sub[name] = Outcome(self.succeeds(body), self.fails(body))

    def succeeds(self, node: Node) -> bool:
        k, kids = node.kind, node.children
        if k in ("log", "set", "wait"):
            return True
        if k == "subtree":
            return self._sub.get(node.use, UNKNOWN).succeeds
        if k == "sequence":
            return all(self.succeeds(c) for c in kids)
        if k == "selector":
            return any(self.succeeds(c) for c in kids)
        if k == "parallel":  # any child failing fails a parallel, whatever its policy
            return bool(kids) and all(self.succeeds(c) for c in kids)
        if k in ("repeat", "retry", "one_shot"):
            return bool(kids) and self.succeeds(kids[0])
        if k == "inverter":
            return bool(kids) and self.fails(kids[0])
        return False

    def fails(self, node: Node) -> bool:
        k, kids = node.kind, node.children
        if k == "subtree":
            return self._sub.get(node.use, UNKNOWN).fails
        if k == "inverter":
            return bool(kids) and self.succeeds(kids[0])
        if k == "sequence":
            return any(self.fails(c) for c in kids)
        if k == "selector":
            return bool(kids) and all(self.fails(c) for c in kids)
        return False


def _check_unreachable(r: Reader, node: Node, outcomes: Outcomes) -> None:
    if node.kind not in ("selector", "sequence"):
        return
    stop = outcomes.succeeds if node.kind == "selector" else outcomes.fails
    for i, child in enumerate(node.children[:-1]):
        if stop(child):
            nxt = node.children[i + 1]
            verb = "always succeeds" if node.kind == "selector" else "always fails"
            r.warn(nxt.path, f"this {node.kind} child can never run: the one before it (`{child.name}`) {verb}")
            return


def check_warnings(
    r: Reader,
    safety: Safety | None,
    roots: Iterable[tuple[str, Node]],
    subtrees: Mapping[str, Node],
    graph: SubtreeGraph,
) -> None:
    """Record the lint's warnings (module docstring) on ``r``."""
    roots = list(roots)
    used = used_subtrees([n for _, n in roots], graph)
    for name in subtrees:
        if name not in used:
            r.warn(
                ("subtrees", name),
                f"subtree `{name}` is never used (no `subtree: {name}` in the tree or the abort path)",
                at_key=True,
            )
    outcomes = Outcomes(subtrees, graph)
    for node in [n for _, root in roots for n in root.walk()] + [n for body in subtrees.values() for n in body.walk()]:
        _check_unreachable(r, node, outcomes)
        if safety is not None:
            if node.kind == "action":
                _check_goals(r, node, safety)
            _check_time(r, node, safety)
