"""Compile a checked :class:`mission.spec.Mission` into py_trees behaviours.

``compile_mission(mission, ctx)`` builds the main tree, ``compile_abort``
the abort tree; each call builds fresh behaviour instances bound to ``ctx``
(a :class:`behaviours.context.MissionContext`). Leaves touch ``ctx`` only when
ticked, so ``ctx=None`` is fine for display only (``maris show``).

Mapping (file kind -> py_trees):

========== ==============================================================
sequence   ``composites.Sequence(memory)``
selector   ``composites.Selector(memory)``
parallel   ``composites.Parallel`` with ``SuccessOnAll(synchronise)`` / ``SuccessOnOne``
timeout    :class:`behaviours.timeout.ClockTimeout` (backend clock)
retry      :class:`behaviours.retry.LoggedRetry` (py_trees Retry + an event per failed attempt)
repeat     ``decorators.Repeat(num_success=times)``
inverter   ``decorators.Inverter``
guard      :func:`behaviours.guard.make_guard` (py_trees EternalGuard: predicate
           checked before every tick of the child; when it fails the child
           is halted, FAILURE)
one_shot   ``decorators.OneShot``
subtree    ``decorators.PassThrough`` named after the use site, over the subtree
leaves     :mod:`behaviours` (action, condition, gripper, wait, set, log, teleop)
========== ==============================================================
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from typing import Any

import py_trees
from py_trees.common import OneShotPolicy, ParallelPolicy

from behaviours.action import KclAction
from behaviours.blackboard_set import SetBlackboard
from behaviours.condition import Condition
from behaviours.context import MissionContext
from behaviours.gripper import GripperCommand
from behaviours.guard import make_guard
from behaviours.log_event import LogEvent
from behaviours.predicates import PredicateEval
from behaviours.retry import LoggedRetry
from behaviours.teleop import HandBack, Teleop, TeleopSettings
from behaviours.timeout import ClockTimeout
from behaviours.wait import Wait

from .spec import Mission, Node

Behaviour = py_trees.behaviour.Behaviour


class MissionCompileError(Exception):
    """A node the compiler cannot build (a loader bug: loaded missions always compile)."""


def compile_mission(mission: Mission, ctx: MissionContext | None) -> Behaviour:
    """Root behaviour of the mission's main tree."""
    return compile_node(mission.tree, ctx, mission.subtrees)


def compile_abort(mission: Mission, ctx: MissionContext | None) -> Behaviour:
    """Root behaviour of the mission's abort path."""
    return compile_node(mission.abort, ctx, mission.subtrees)


def compile_node(
    node: Node, ctx: MissionContext | None, subtrees: Mapping[str, Node], _stack: tuple[str, ...] = ()
) -> Behaviour:
    """Build the behaviour for ``node`` and its descendants."""
    build = _BUILDERS.get(node.kind)
    if build is None:
        raise MissionCompileError(f"{node.mark}: no compiler for node kind {node.kind!r}")
    return build(node, ctx, subtrees, _stack)


def _kids(node: Node, ctx, subtrees, stack) -> list[Behaviour]:
    return [compile_node(c, ctx, subtrees, stack) for c in node.children]


def _only_child(node: Node, ctx, subtrees, stack) -> Behaviour:
    return compile_node(node.children[0], ctx, subtrees, stack)


def _sequence(node, ctx, subtrees, stack):
    return py_trees.composites.Sequence(
        node.name, memory=node.params["memory"], children=_kids(node, ctx, subtrees, stack)
    )


def _selector(node, ctx, subtrees, stack):
    return py_trees.composites.Selector(
        node.name, memory=node.params["memory"], children=_kids(node, ctx, subtrees, stack)
    )


def _parallel(node, ctx, subtrees, stack):
    if node.params["policy"] == "success_on_one":
        policy: ParallelPolicy.Base = ParallelPolicy.SuccessOnOne()
    else:
        policy = ParallelPolicy.SuccessOnAll(synchronise=node.params["synchronise"])
    return py_trees.composites.Parallel(node.name, policy=policy, children=_kids(node, ctx, subtrees, stack))


def _timeout(node, ctx, subtrees, stack):
    return ClockTimeout(node.name, _only_child(node, ctx, subtrees, stack), ctx, node.params["duration_s"])


def _retry(node, ctx, subtrees, stack):
    return LoggedRetry(node.name, _only_child(node, ctx, subtrees, stack), ctx, node.params["attempts"])


def _repeat(node, ctx, subtrees, stack):
    return py_trees.decorators.Repeat(
        node.name, _only_child(node, ctx, subtrees, stack), num_success=node.params["times"]
    )


def _inverter(node, ctx, subtrees, stack):
    return py_trees.decorators.Inverter(node.name, _only_child(node, ctx, subtrees, stack))


def _one_shot(node, ctx, subtrees, stack):
    policy = OneShotPolicy.ON_SUCCESSFUL_COMPLETION if node.params["on"] == "success" else OneShotPolicy.ON_COMPLETION
    return py_trees.decorators.OneShot(node.name, _only_child(node, ctx, subtrees, stack), policy=policy)


def _guard(node, ctx, subtrees, stack):
    predicate = PredicateEval.from_spec(node.params["condition"])
    return make_guard(node.name, _only_child(node, ctx, subtrees, stack), ctx, predicate)


def _subtree(node, ctx, subtrees, stack):
    use = node.params["use"]
    if use in stack:
        raise MissionCompileError(f"{node.mark}: subtree cycle through {use!r}")
    body = compile_node(subtrees[use], ctx, subtrees, stack + (use,))
    return py_trees.decorators.PassThrough(node.name, body)


def _action(node, ctx, subtrees, stack):
    p = node.params
    until = PredicateEval.from_spec(p["until"]) if p.get("until") is not None else None
    return KclAction(
        node.name,
        ctx,
        p["run"],
        targets=p.get("targets"),
        until=until,
        timeout_s=p.get("timeout_s"),
        track_detection=p.get("track_detection"),
    )


def _condition(node, ctx, subtrees, stack):
    return Condition(node.name, ctx, PredicateEval.from_spec(node.params["predicate"]))


def _gripper(node, ctx, subtrees, stack):
    p = node.params
    return GripperCommand(
        node.name,
        ctx,
        p["command"],
        shape=p.get("shape"),
        current_limit_a=p.get("current_limit_a"),
        timeout_s=p.get("timeout_s"),
        wait=p.get("wait", True),
    )


def _wait(node, ctx, subtrees, stack):
    return Wait(node.name, ctx, node.params["duration_s"])


def _set(node, ctx, subtrees, stack):
    return SetBlackboard(node.name, ctx, node.params["key"], value=node.params.get("value"), add=node.params.get("add"))


def _log(node, ctx, subtrees, stack):
    return LogEvent(node.name, ctx, node.params["message"], node.params["level"])


def _teleop(node, ctx, subtrees, stack):
    p = node.params
    hb = p["handback"]
    until = PredicateEval.from_spec(hb["until"]) if hb.get("until") is not None else None
    settings = TeleopSettings(
        modes=tuple(p["modes"]),
        start_mode=p.get("start_mode"),
        inputs=tuple(p["inputs"]) if p.get("inputs") else None,
        frame=p["frame"],
        deadman_s=p["deadman_s"],
        goal_max_age_s=p["goal_max_age_s"],
        timeout_s=p.get("timeout_s"),
        handback=HandBack(button=hb["button"], service=hb["service"], until=until),
    )
    return Teleop(node.name, ctx, settings)


_BUILDERS: dict[str, Callable[[Node, Any, Mapping[str, Node], tuple[str, ...]], Behaviour]] = {
    "sequence": _sequence,
    "selector": _selector,
    "parallel": _parallel,
    "timeout": _timeout,
    "retry": _retry,
    "repeat": _repeat,
    "inverter": _inverter,
    "one_shot": _one_shot,
    "guard": _guard,
    "subtree": _subtree,
    "action": _action,
    "condition": _condition,
    "gripper": _gripper,
    "wait": _wait,
    "set": _set,
    "log": _log,
    "teleop": _teleop,
}
