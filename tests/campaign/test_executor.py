"""Executor: ordering, failing runs, dying workers, the Dask path.

These tests drive the executor with small module-level run functions (the
executor's contract does not depend on what a run does); the real single-run
function is exercised in test_campaign_real.py.
"""

import io
import os

import pytest

from mission.campaign.executor import execute, guarded_call
from mission.campaign.plan import plan_campaign
from mission.campaign.progress import Progress
from mission.campaign.records import RunRecord


def seeded_outcome(spec):
    """Outcome decided by the seed; seeds divisible by 5 raise."""
    if spec.seed % 5 == 0:
        raise ValueError(f"bad seed {spec.seed}")
    outcome = ["success", "timeout", "grasp_missed", "success"][spec.seed % 4]
    return RunRecord(spec.index, spec.seed, outcome, duration_s=float(spec.seed % 97))


def dies_on_index_2(spec):
    if spec.index == 2:
        os._exit(3)
    return RunRecord(spec.index, spec.seed, "success", duration_s=1.0)


def returns_garbage(spec):
    return {"outcome": "success"}


def _plan(n, seed=11):
    return plan_campaign("m.yaml", "pool_clear", n, seed)


def test_guarded_call_records_exception_and_traceback():
    plan = _plan(40)
    bad = next(s for s in plan.runs if s.seed % 5 == 0)
    rec = guarded_call(seeded_outcome, bad)
    assert rec.outcome == "error" and rec.index == bad.index and rec.seed == bad.seed
    assert rec.error == f"ValueError: bad seed {bad.seed}"
    assert "Traceback" in rec.traceback and "seeded_outcome" in rec.traceback
    assert guarded_call(returns_garbage, plan.runs[0]).error.startswith("TypeError")


def test_parallel_equals_serial_and_is_ordered():
    plan = _plan(30)
    seen = []
    par = execute(plan, seeded_outcome, workers=2, on_record=seen.append)
    ser = [guarded_call(seeded_outcome, s) for s in plan.runs]
    assert [r.index for r in par] == list(range(30))
    strip = lambda rs: [(r.index, r.seed, r.outcome, repr(r.duration_s), r.error) for r in rs]  # noqa: E731
    assert strip(par) == strip(ser)
    assert sorted(r.index for r in seen) == list(range(30))
    assert any(r.outcome == "error" for r in par) and any(r.success for r in par)


def test_dying_worker_is_one_failed_run():
    plan = _plan(6)
    recs = execute(plan, dies_on_index_2, workers=2)
    assert [r.index for r in recs] == list(range(6))
    assert recs[2].outcome == "error" and "worker process died" in recs[2].error
    assert all(r.success for i, r in enumerate(recs) if i != 2)


def test_dask_cluster_path(tmp_path):
    distributed = pytest.importorskip("distributed")
    mission = tmp_path / "m.yaml"  # the cluster path checks that its workers can read the mission file
    mission.write_text("# stand-in\n")
    plan = plan_campaign(str(mission), "pool_clear", 8, 11)
    with distributed.LocalCluster(
        n_workers=2, threads_per_worker=1, processes=False, protocol="tcp", host="127.0.0.1", dashboard_address=None
    ) as cluster:
        assert cluster.scheduler_address.startswith("tcp://127.0.0.1:")
        recs = execute(plan, seeded_outcome, address=cluster.scheduler_address)
    ser = [guarded_call(seeded_outcome, s) for s in plan.runs]
    assert [(r.index, r.outcome, r.error) for r in recs] == [(r.index, r.outcome, r.error) for r in ser]


def test_progress_plain_lines_and_tty_bar():
    out = io.StringIO()
    p = Progress(20, out, tty=False)
    for i in range(20):
        p(RunRecord(i, i, "success" if i % 2 else "error"))
    lines = out.getvalue().splitlines()
    assert len(lines) == 10 and lines[-1].startswith("20/20 runs, 10 successes, 10 errors")
    out = io.StringIO()
    p = Progress(3, out, tty=True, width=6)
    for i in range(3):
        p(RunRecord(i, i, "success"))
    text = out.getvalue()
    assert text.count("\r") == 3 and "[######] 3/3 runs" in text and text.endswith("\n")


def test_the_default_run_function_is_warmed_up_once_before_the_fork(monkeypatch):
    """With the real run function the parent loads the runtime and its kernels once
    (the forked workers inherit them); a custom run function is left alone; and a
    warm-up on inputs the runs will refuse does not raise (the runs report them)."""
    import dataclasses
    import multiprocessing

    import mission.campaign.single as single

    if "fork" not in multiprocessing.get_all_start_methods():
        pytest.skip("no fork start method: each spawned worker loads for itself")
    calls = []
    real_warm_up = single.warm_up
    monkeypatch.setattr(single, "warm_up", lambda spec: calls.append(spec.index))
    monkeypatch.setattr(single, "run_one", seeded_outcome)  # what the executor takes for the real one
    execute(_plan(6), seeded_outcome, workers=2)
    assert calls == [0]
    execute(_plan(6), returns_garbage, workers=2)
    assert calls == [0]  # not for another run function
    real_warm_up(dataclasses.replace(_plan(1).runs[0], scenario="no_such_scenario"))
