"""The Dask path of :func:`mission.campaign.executor.execute`.

A scheduler address is all it needs (``tcp://host:8786``: a real cluster, or a
``distributed.LocalCluster`` in the tests). Each run is one Dask task running
:func:`mission.campaign.executor.guarded_call`, so a run that raises comes back
as an ``error`` record. What the cluster adds, and how nothing gets lost:

* a worker process that dies mid-run (killed, out of memory, segfault): the
  scheduler reruns the task on another worker (Dask's own rescheduling, up to
  ``distributed.scheduler.allowed-failures`` times, 3 by default, a setting of
  the scheduler); past that it reports ``KilledWorker``. The scheduler also
  blames the runs merely queued on the dying worker, so once every other run
  is done each ``KilledWorker`` run is run again, alone on the cluster; only a
  run that kills its workers again is recorded as an ``error`` saying so;
* each result is released as soon as it is read: the scheduler keeps a
  result the client holds on the worker that computed it, and recomputes all
  of those when that worker dies (65 finished runs of a 1,000-run campaign ran
  again after one worker was killed, before this);
* a task cancelled or lost with the scheduler connection is an ``error``
  record too; after the loop, any planned run without a record (never seen so
  far) gets one: every run index is in the result exactly once;
* the per-run wall-clock limit is checked inside the run at every supervisor
  tree tick (:mod:`mission.campaign.deadline`; Dask runs tasks in threads, so
  the hard SIGALRM limit of local runs does not apply here).

Workers must run one task at a time (``dask worker --nthreads 1``): runs keep
per-process state (py_trees' blackboard, the Numba kernels' buffers), so two
runs must never share a process at the same time. A cluster whose workers have
more threads is refused with a message saying so, and so is one whose workers
cannot read the mission or scenario file (they must be on a path every worker
reads, like the ``--logs`` directory; ``maris campaign --address`` passes
absolute paths).
"""

from __future__ import annotations

import functools
import os
import traceback as tb
from collections.abc import Callable

from mission.campaign.plan import RunSpec
from mission.campaign.records import RunRecord

#: how long to wait for the scheduler and for its first worker, s
CONNECT_TIMEOUT_S = 20.0


class ClusterError(RuntimeError):
    """The cluster cannot run the campaign (unreachable, no worker, wrong setup)."""


def _connect(address: str):
    try:
        from dask.distributed import Client  # optional: the `cluster` extra
    except ImportError as exc:  # pragma: no cover - depends on the install
        raise ClusterError("--address needs Dask distributed: pip install 'maris-uvms[cluster]'") from exc
    try:
        client = Client(address, timeout=f"{CONNECT_TIMEOUT_S:g}s")
    except (OSError, TimeoutError, ValueError) as exc:
        raise ClusterError(f"cannot reach the Dask scheduler at {address}: {exc}") from None
    try:
        client.wait_for_workers(1, timeout=CONNECT_TIMEOUT_S)
    except (TimeoutError, OSError) as exc:
        client.close()
        raise ClusterError(f"the Dask scheduler at {address} has no worker ({exc})") from None
    threaded = {
        addr: w.get("nthreads", 1)
        for addr, w in client.scheduler_info()["workers"].items()
        if w.get("nthreads", 1) != 1
    }
    if threaded:
        client.close()
        worker, n = next(iter(threaded.items()))
        raise ClusterError(
            f"Dask worker {worker} runs {n} threads: campaign runs need one thread per worker process "
            "(start workers with `dask worker ADDRESS --nthreads 1 --nworkers N`)"
        )
    return client


def missing_files(paths: list[str]) -> list[str]:
    """(Runs on each worker.) The ``paths`` this process cannot read, each
    with the working directory relative paths are taken from."""

    return [f"{p} (working directory {os.getcwd()})" for p in paths if not os.access(p, os.R_OK)]


def _check_files(client, specs: list[RunSpec]) -> None:
    """Refuse a campaign whose mission or scenario file some worker cannot read
    (relative paths on another working directory, or no shared filesystem)."""

    paths = sorted({s.mission_path for s in specs} | {s.scenario for s in specs if os.path.isfile(s.scenario)})
    try:
        report = client.run(missing_files, paths)
    except Exception:  # noqa: BLE001 - cannot check (workers of another version, say): the runs will tell
        return
    bad = {worker: missing for worker, missing in report.items() if missing}
    if bad:
        worker, missing = next(iter(bad.items()))
        raise ClusterError(
            f"Dask worker {worker} cannot read {', '.join(missing)}: the mission and scenario "
            "files must be readable by every worker at the same path (absolute paths on a shared "
            f"directory); {len(bad)} of {len(report)} workers affected"
        )


def _failed(spec: RunSpec, exc: BaseException, error_record: Callable) -> RunRecord:
    name = type(exc).__name__
    if name == "KilledWorker":
        text = f"worker process died during the run, on every worker that tried it ({name}: {exc})"
    elif name in ("CancelledError", "FutureCancelledError"):
        text = f"run cancelled by the cluster (lost scheduler connection?) ({name}: {exc})"
    else:
        text = f"{name}: {exc}"
    return error_record(spec, text, "".join(tb.format_exception(exc)))


def execute_on_cluster(
    specs: list[RunSpec],
    run_fn: Callable,
    address: str,
    emit: Callable[[RunRecord], None],
    guarded_call: Callable,
    error_record: Callable,
) -> dict[int, RunRecord]:
    """Run ``specs`` on the Dask cluster at ``address``; one record per spec
    index, ``emit`` called in this process as each arrives."""
    from dask.distributed import as_completed  # optional: the `cluster` extra (checked by _connect)

    done: dict[int, RunRecord] = {}
    client = _connect(address)
    call = functools.partial(guarded_call, run_fn)
    futures = []
    try:
        _check_files(client, specs)
        futures = client.map(call, specs, pure=False)
        by_key = {f.key: s for f, s in zip(futures, specs)}
        suspects: list[RunSpec] = []
        for fut in as_completed(futures):
            spec = by_key[fut.key]
            try:
                record = fut.result()
            except Exception as exc:  # noqa: BLE001 - KilledWorker, cancellation, unpicklable results
                if type(exc).__name__ == "KilledWorker":
                    suspects.append(spec)  # killed its workers, or was only queued on them
                    continue
                record = _failed(spec, exc, error_record)
            finally:
                # let go of the result once read: a result this client still holds stays in
                # its worker's memory, and when that worker dies the scheduler recomputes
                # every result it held (runs already done and reported, run again)
                fut.release()
            done[spec.index] = record
            emit(record)
        # The scheduler also blames the runs merely queued on a dying worker:
        # rerun each suspect alone on the cluster (nothing queued beside it);
        # only a run that kills its workers again is an error.
        for spec in suspects:
            fut = client.submit(call, spec, pure=False)
            futures.append(fut)
            try:
                record = fut.result()
            except Exception as exc:  # noqa: BLE001
                record = _failed(spec, exc, error_record)
            done[spec.index] = record
            emit(record)
        for spec in specs:  # never drop a run, whatever happened to its future
            if spec.index not in done:
                done[spec.index] = record = error_record(spec, "no result came back from the cluster")
                emit(record)
    except KeyboardInterrupt:
        client.cancel(futures)
        raise
    finally:
        client.close()
    return done
