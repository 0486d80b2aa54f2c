"""KclAction with the real UvmsController on the simulator: convergence,
retries of the same action, field faults, and the halt contract."""

from __future__ import annotations

import numpy as np
import pytest
from py_trees.common import Status

from behaviours.action import KclAction
from behaviours.predicates import PredicateEval


@pytest.mark.slow
def test_transport_converges_with_the_real_controller(make_kcl_ctx):
    ctx = make_kcl_ctx()
    leaf = KclAction("Fold", ctx, "transport", timeout_s=60)
    assert ctx.run(leaf, max_s=60) == Status.SUCCESS, leaf.feedback_message
    tel = ctx.controller.telemetry()
    assert tel["action"] == "transport" and tel["convergence"] <= 0.02 and tel["transition_progress"] == 1.0
    assert 1.0 < ctx.now() < 40.0


def test_retried_action_does_not_finish_on_its_previous_errors(make_kcl_ctx):
    ctx = make_kcl_ctx()
    first = KclAction("Fold", ctx, "transport", timeout_s=60)
    assert ctx.run(first, max_s=60) == Status.SUCCESS
    again = KclAction(
        "Fold again",
        ctx,
        "transport",
        until=PredicateEval("converged", {"max_error": None, "for_s": 0.5}),
        timeout_s=60,
    )
    again.tick_once()
    assert again.status == Status.RUNNING  # same action, already converged: needs fresh steps and 0.5 s
    t0 = ctx.now()
    assert ctx.run(again, max_s=10) == Status.SUCCESS
    assert 0.5 <= ctx.now() - t0 <= 1.0


def test_nan_attitude_fails_the_action_and_stops_motion(make_kcl_ctx):
    ctx = make_kcl_ctx()
    leaf = KclAction("Survey", ctx, "survey", targets={"vehicle_goal": {"north_m": 20.0}}, timeout_s=60)
    assert ctx.run(leaf, max_s=2.0) == Status.RUNNING
    ctx.sim.inject("ahrs_nan")
    assert ctx.run(leaf, max_s=5.0) == Status.FAILURE
    assert "controller fault" in leaf.feedback_message
    assert ctx.motion_stops == 1 and ctx.controller.stopped
    assert ctx.sim.ground_truth()["vehicle"]["commanded_velocity"] == [0.0] * 6


def test_interrupt_stops_the_real_controller(make_kcl_ctx):
    ctx = make_kcl_ctx()
    leaf = KclAction("Survey", ctx, "survey", targets={"vehicle_goal": {"north_m": 20.0}}, timeout_s=60)
    assert ctx.run(leaf, max_s=3.0) == Status.RUNNING
    assert np.any(np.abs(ctx.controller.vehicle_step(ctx.measure(), ctx.now())) > 0.01)
    leaf.stop(Status.INVALID)
    assert ctx.controller.telemetry()["stopped"]
    assert np.all(ctx.controller.vehicle_step(ctx.measure(), ctx.now()) == 0.0)
    assert np.all(ctx.controller.arm_step(ctx.measure(), ctx.now()) == 0.0)
