"""Executing a campaign's runs: local process pool, or a Dask cluster.

Contract: :func:`execute` returns one :class:`RunRecord` per planned run, sorted
by run index, whatever order the workers finished in. A run that raises becomes
an ``error`` record carrying the exception text and traceback; a worker process
that dies (segfault, OOM kill) does not take the campaign with it: the runs that
had not finished are re-run each in its own process, and a run that kills its
process again is recorded as an ``error``.

Each run has an optional wall-clock limit (``RunSpec.timeout_s``,
:mod:`mission.campaign.deadline`); a run past it is an ``error`` record.

Local execution uses :class:`concurrent.futures.ProcessPoolExecutor` (fork start
method where available: workers inherit already imported modules; for the
default run function this process first imports the runtime and loads the
compiled kernels once, :func:`mission.campaign.single.warm_up`, so that no
worker pays for it). The cluster
path (:mod:`mission.campaign.cluster`) uses Dask distributed: a scheduler
address is all it needs, it is pure Python with a small install
(``pip install maris-uvms[cluster]``), and its futures map one-to-one onto
ours. Ray would also work but brings a large binary wheel and its own runtime
daemons for what is here a plain map over runs. Workers of the cluster must
have this package installed (same version) and run one thread each.
"""

from __future__ import annotations

import functools
import multiprocessing
import os
import time
import traceback as tb
from collections.abc import Callable, Iterable
from concurrent.futures import ProcessPoolExecutor, ThreadPoolExecutor, as_completed
from concurrent.futures.process import BrokenProcessPool

from mission.campaign import single
from mission.campaign.cluster import execute_on_cluster
from mission.campaign.deadline import run_deadline
from mission.campaign.plan import CampaignPlan, RunSpec
from mission.campaign.records import RunRecord

RunFn = Callable[[RunSpec], RunRecord]
OnRecord = Callable[[RunRecord], None]


def error_record(spec: RunSpec, error: str, traceback: str | None = None, wall_s: float = float("nan")) -> RunRecord:
    """The record of a run that raised or whose worker died."""
    return RunRecord(
        index=spec.index,
        seed=spec.seed,
        outcome="error",
        failure_cause="error",
        error=error,
        traceback=traceback,
        log_path=spec.log_path,
        wall_s=wall_s,
    )


def guarded_call(run_fn: RunFn, spec: RunSpec) -> RunRecord:
    """Call ``run_fn(spec)`` within the spec's wall-clock limit
    (:func:`mission.campaign.deadline.run_deadline`); any exception, a
    :class:`~mission.campaign.deadline.RunTimeout` included, becomes an
    ``error`` record. Also stamps the record with the spec's index, seed and
    the wall time.
    """
    start = time.perf_counter()
    try:
        with run_deadline(spec.timeout_s):
            record = run_fn(spec)
        if not isinstance(record, RunRecord):
            raise TypeError(f"run function returned {type(record).__name__}, expected RunRecord")
    except KeyboardInterrupt:
        raise
    except BaseException as exc:  # noqa: BLE001 - a run must never crash the campaign
        return error_record(spec, f"{type(exc).__name__}: {exc}", tb.format_exc(), time.perf_counter() - start)
    record.index, record.seed = spec.index, spec.seed
    record.wall_s = time.perf_counter() - start
    return record


def default_workers() -> int:
    """Number of local worker processes: one per CPU."""
    return max(1, os.cpu_count() or 1)


def _mp_context():
    methods = multiprocessing.get_all_start_methods()
    return multiprocessing.get_context("fork" if "fork" in methods else "spawn")


def _run_isolated(run_fn: RunFn, spec: RunSpec) -> RunRecord:
    """One run in a fresh single-process pool, so a dying process hits only this run."""
    start = time.perf_counter()
    try:
        with ProcessPoolExecutor(1, mp_context=_mp_context()) as pool:
            return pool.submit(guarded_call, run_fn, spec).result()
    except BrokenProcessPool as exc:
        return error_record(spec, f"worker process died during the run ({exc})", None, time.perf_counter() - start)
    except Exception as exc:  # e.g. an unpicklable result
        return error_record(spec, f"{type(exc).__name__}: {exc}", tb.format_exc(), time.perf_counter() - start)


def _execute_local(specs: list[RunSpec], run_fn: RunFn, workers: int, emit: OnRecord) -> dict[int, RunRecord]:
    done: dict[int, RunRecord] = {}
    context = _mp_context()

    if run_fn is single.run_one and context.get_start_method() == "fork":
        single.warm_up(specs[0])  # once here: the forked workers inherit the loaded modules and kernels
    pool = ProcessPoolExecutor(max(1, min(workers, len(specs))), mp_context=context)
    try:
        futures = {pool.submit(guarded_call, run_fn, s): s for s in specs}
        for fut in as_completed(futures):
            spec = futures[fut]
            try:
                record = fut.result()
            except BrokenProcessPool:
                continue  # re-run below, isolated
            except Exception as exc:  # pickling problems and the like
                record = error_record(spec, f"{type(exc).__name__}: {exc}", tb.format_exc())
            done[spec.index] = record
            emit(record)
    finally:
        pool.shutdown(wait=True, cancel_futures=True)
    leftovers = [s for s in specs if s.index not in done]
    if leftovers:
        with ThreadPoolExecutor(max(1, min(workers, len(leftovers)))) as threads:
            for record in threads.map(functools.partial(_run_isolated, run_fn), leftovers):
                done[record.index] = record
                emit(record)
    return done


def execute(
    plan: CampaignPlan | Iterable[RunSpec],
    run_fn: RunFn | None = None,
    *,
    workers: int | None = None,
    address: str | None = None,
    on_record: OnRecord | None = None,
) -> list[RunRecord]:
    """Run every planned run; return the records sorted by run index.

    ``run_fn`` defaults to :func:`mission.campaign.single.run_one` and must be a
    module-level function (it is pickled to the workers). ``workers`` defaults
    to the CPU count; ``address`` (``tcp://host:8786``) selects a Dask cluster
    instead of local processes. ``on_record`` is called in this process as each
    run finishes (progress bars). Raises :class:`mission.campaign.cluster.ClusterError`
    when the cluster at ``address`` cannot run the campaign.
    """
    specs = list(plan.runs if isinstance(plan, CampaignPlan) else plan)
    if run_fn is None:
        run_fn = single.run_one
    emit = on_record or (lambda _r: None)
    if not specs:
        return []
    if address:
        done = execute_on_cluster(specs, run_fn, address, emit, guarded_call, error_record)
    else:
        done = _execute_local(specs, run_fn, workers or default_workers(), emit)
    return [done[s.index] for s in specs]
