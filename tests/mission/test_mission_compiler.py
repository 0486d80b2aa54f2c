"""Compiler: every node kind compiles to the right py_trees behaviour, with
readable names, and behaves when ticked on the simulator."""

from __future__ import annotations

import textwrap

import py_trees
import pytest
from py_trees.common import Status

from behaviours.action import KclAction
from behaviours.condition import Condition
from behaviours.gripper import GripperCommand
from behaviours.timeout import ClockTimeout
from mission.compiler import compile_abort, compile_mission
from mission.loader import load_mission_text

HEADER = """\
name: t
safety:
  max_depth_m: 10
  min_altitude_m: 0.5
  max_duration_s: 60
  geofence: {north_m: [-50, 50], east_m: [-50, 50], down_m: [0, 10]}
blackboard:
  n: 0
  flag: false
abort:
  sequence:
    name: Abort
    children:
      - action: {name: Hold, run: hold, timeout_s: 5}
"""


def mission(tree: str, extra: str = ""):
    return load_mission_text(
        HEADER + "tree:\n" + textwrap.indent(textwrap.dedent(tree), "  ") + textwrap.dedent(extra), "m.yaml"
    )


def build(tree: str, ctx, extra: str = ""):
    m = mission(tree, extra)
    ctx.blackboard.__init__({k: v.type for k, v in m.blackboard.items()}, m.initial_blackboard())
    return compile_mission(m, ctx)


@pytest.fixture
def ctx(make_ctx):
    return make_ctx({"n": "int", "flag": "bool"}, {"n": 0, "flag": False})


def test_every_kind_compiles_to_its_behaviour(ctx):
    root = build(
        """\
        sequence:
          name: Root
          children:
            - selector: {children: [{wait: {duration_s: 0}}]}
            - fallback: {memory: false, children: [{log: {message: hi}}]}
            - parallel: {policy: success_on_one, children: [{wait: {duration_s: 0}}]}
            - timeout: {duration_s: 3, child: {action: {run: grasp}}}
            - retry: {attempts: 2, child: {condition: {converged: {}}}}
            - repeat: {times: 2, child: {set: {key: n, add: 1}}}
            - inverter: {child: {condition: {blackboard: {key: flag, equals: true}}}}
            - guard: {condition: {depth_m: {max: 9}}, child: {gripper: {command: open}}}
            - one_shot: {child: {wait: {duration_s: 0}}}
            - subtree: {name: Use it, use: inner}
        """,
        ctx,
        extra="subtrees:\n  inner: {wait: {name: Inner wait, duration_s: 0}}\n",
    )
    kinds = [type(c).__name__ for c in root.children]
    assert kinds == [
        "Selector",
        "Selector",
        "Parallel",
        "ClockTimeout",
        "LoggedRetry",
        "Repeat",
        "Inverter",
        "EternalGuard",
        "OneShot",
        "PassThrough",
    ]
    assert root.name == "Root" and root.children[1].memory is False
    assert isinstance(root.children[3].decorated, KclAction) and root.children[3].name == "Timeout 3 s"
    assert isinstance(root.children[6].decorated, Condition)
    assert isinstance(root.children[7].decorated, GripperCommand)
    assert root.children[9].name == "Use it" and root.children[9].decorated.name == "Inner wait"
    abort = compile_abort(mission("wait: {duration_s: 1}"), ctx)
    assert abort.name == "Abort" and isinstance(abort.children[0], KclAction)


def test_sequence_of_small_leaves_runs_to_success(ctx, tick):
    root = build(
        """\
        sequence:
          children:
            - log: {message: start}
            - repeat: {times: 3, child: {set: {key: n, add: 1}}}
            - condition: {blackboard: {key: n, equals: 3}}
            - inverter: {child: {condition: {blackboard: {key: flag, equals: true}}}}
            - wait: {duration_s: 0.5}
            - set: {key: flag, value: true}
        """,
        ctx,
    )
    assert tick(root, ctx, max_s=5) == Status.SUCCESS
    assert ctx.blackboard.get("n") == 3 and ctx.blackboard.get("flag") is True
    assert ctx.events.kinds() == ["mission_log"]


def test_selector_falls_back_and_retry_counts_attempts(ctx, tick):
    root = build(
        """\
        selector:
          children:
            - retry:
                attempts: 3
                child:
                  sequence:
                    children:
                      - set: {key: n, add: 1}
                      - condition: {blackboard: {key: n, above: 10}}
            - log: {message: gave up}
        """,
        ctx,
    )
    assert tick(root, ctx, max_s=5) == Status.SUCCESS
    assert ctx.blackboard.get("n") == 3
    assert ctx.events.events[-1]["message"] == "gave up"
    attempts = [e for e in ctx.events.events if e["kind"] == "attempt_failed"]
    assert [e["attempt"] for e in attempts] == [1, 2, 3]
    assert "failed at Check n above 10" in attempts[0]["message"]


def test_timeout_decorator_halts_the_action_and_stops_motion(ctx, tick):
    root = build("timeout: {duration_s: 1, child: {action: {run: grasp}}}", ctx)
    assert tick(root, ctx, max_s=5) == Status.FAILURE
    assert 1.0 <= ctx.now() <= 1.2
    assert ctx.motion_stops == 1 and ctx.controller.stopped


def test_guard_halts_the_child_when_its_condition_breaks(ctx, tick):
    root = build(
        """\
        guard:
          condition: {blackboard: {key: flag, equals: false}}
          child: {action: {run: survey, timeout_s: 100}}
        """,
        ctx,
    )
    tick(root, ctx, max_s=0.5)
    assert root.status == Status.RUNNING
    ctx.blackboard.set("flag", True)
    root.tick_once()
    assert root.status == Status.FAILURE
    assert ctx.motion_stops == 1 and "guard_failed" in ctx.events.kinds() and "halted" in ctx.events.kinds()


def test_parallel_success_on_one_halts_the_other_branch(ctx, tick):
    root = build(
        """\
        parallel:
          policy: success_on_one
          children:
            - action: {run: hold, timeout_s: 100}
            - wait: {duration_s: 1}
        """,
        ctx,
    )
    assert tick(root, ctx, max_s=5) == Status.SUCCESS
    assert ctx.motion_stops == 1


def test_one_shot_runs_its_child_once(ctx, tick):
    root = build("one_shot: {child: {set: {key: n, add: 1}}}", ctx)
    for _ in range(3):
        root.tick_once()
    assert ctx.blackboard.get("n") == 1 and root.status == Status.SUCCESS


def test_clock_timeout_is_used_not_wall_clock(ctx):
    root = build("timeout: {duration_s: 2, child: {wait: {duration_s: 10}}}", ctx)
    assert isinstance(root, ClockTimeout)


def test_display_compile_needs_no_context():
    root = compile_mission(mission("sequence: {children: [{action: {run: grasp, timeout_s: 3}}]}"), None)
    text = py_trees.display.unicode_tree(root)
    assert "Action grasp" in text
