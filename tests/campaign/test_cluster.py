"""Campaigns on a real Dask cluster (LocalCluster, worker processes under
nannies, TCP on 127.0.0.1): a worker killed mid-run loses no run, a run that
kills every worker it lands on is an error, wall-clock limits, wrong clusters.

The runs are stand-ins (mission.campaign.testing: importable by the spawned
workers) that sleep; the executor's contract does not depend on what a run does.
"""

import os
import signal
import threading
import time

import pytest

from mission.campaign import cluster as cluster_mod
from mission.campaign.cluster import ClusterError
from mission.campaign.executor import execute
from mission.campaign.plan import plan_campaign
from mission.campaign.testing import hanging_run, slow_run

distributed = pytest.importorskip("distributed")
pytestmark = pytest.mark.realtime  # cluster workers killed mid-run
dask = pytest.importorskip("dask")


@pytest.fixture(scope="module")
def cluster():
    """Three single-threaded worker processes. allowed-failures 0 (the
    scheduler's setting): the first death of its worker makes a task a
    KilledWorker at once, so these tests exercise the executor's own rerun of
    such runs, alone on the cluster."""
    with dask.config.set({"distributed.scheduler.allowed-failures": 0}):
        with distributed.LocalCluster(
            n_workers=3, threads_per_worker=1, processes=True, protocol="tcp", host="127.0.0.1", dashboard_address=None
        ) as c:
            yield c


@pytest.fixture(scope="module")
def mission(tmp_path_factory) -> str:
    """A file the workers can read (the stand-in runs do not parse it)."""
    path = tmp_path_factory.mktemp("m") / "m.yaml"
    path.write_text("# stand-in\n")
    return str(path)


def _wait_for(predicate, timeout_s=60.0):
    end = time.monotonic() + timeout_s
    while time.monotonic() < end:
        found = predicate()
        if found:
            return found
        time.sleep(0.02)
    raise AssertionError("condition not met in time")


def _in_thread(fn):
    box = {}
    thread = threading.Thread(target=lambda: box.setdefault("value", fn()), daemon=True)
    thread.start()
    return thread, box


@pytest.mark.slow
def test_killing_a_worker_mid_run_loses_no_run(mission, cluster, tmp_path):
    """SIGKILL the worker process in the middle of run 0: it is rerun on
    another worker; every run index is in the result exactly once."""
    hold = tmp_path / "hold"
    hold.touch()  # run 0 waits while this file exists: it is surely mid-run when killed
    markers = tmp_path / "markers"
    markers.mkdir()
    n = 10
    plan = plan_campaign(
        mission,
        "pool_clear",
        n,
        3,
        overrides={"sleep_s": 0.2, "marker_dir": str(markers), "hold_file": str(hold), "hold_on": [0]},
    )
    seen = []
    thread, box = _in_thread(lambda: execute(plan, slow_run, address=cluster.scheduler_address, on_record=seen.append))
    first = _wait_for(lambda: [m for m in markers.iterdir() if m.name.startswith("0.")])
    pid = int(first[0].name.split(".")[1])
    os.kill(pid, signal.SIGKILL)
    hold.unlink()
    thread.join(timeout=120)
    records = box["value"]
    assert [r.index for r in records] == list(range(n))
    assert sorted(r.index for r in seen) == list(range(n))  # progress saw each run once
    attempts = sorted(int(m.name.split(".")[1]) for m in markers.iterdir() if m.name.startswith("0."))
    assert len(attempts) == 2 and pid in attempts  # killed once, rerun in another process
    assert all(r.outcome == "success" for r in records), [(r.index, r.error) for r in records if r.error]


@pytest.mark.slow
def test_a_dying_worker_costs_only_its_unfinished_runs(mission, cluster, tmp_path):
    """Runs whose record came back before their worker died are not run again:
    the campaign lets go of each result once read (a result the client still
    holds lives in its worker's memory, and Dask recomputes all of those when
    the worker dies: on a long campaign, every run that worker ever did)."""
    hold = tmp_path / "hold"
    hold.touch()
    markers = tmp_path / "markers"
    markers.mkdir()
    n, held = 12, 9
    plan = plan_campaign(
        mission,
        "pool_clear",
        n,
        6,
        overrides={"sleep_s": 0.05, "marker_dir": str(markers), "hold_file": str(hold), "hold_on": [held]},
    )
    seen = []
    thread, box = _in_thread(lambda: execute(plan, slow_run, address=cluster.scheduler_address, on_record=seen.append))

    def done_on_the_held_worker():
        started = [m.name.split(".") for m in markers.iterdir()]
        pids = [int(p) for i, p in started if int(i) == held]
        if not pids:
            return None
        reported = {r.index for r in seen}
        earlier = [int(i) for i, p in started if int(p) == pids[0] and int(i) in reported]
        return (pids[0], earlier) if earlier else None

    pid, earlier = _wait_for(done_on_the_held_worker)
    time.sleep(0.5)  # the release of the results read reaches the scheduler
    os.kill(pid, signal.SIGKILL)
    hold.unlink()
    thread.join(timeout=120)
    records = box["value"]
    assert [r.index for r in records] == list(range(n))
    assert all(r.outcome == "success" for r in records), [(r.index, r.error) for r in records if r.error]
    starts = [int(m.name.split(".")[0]) for m in markers.iterdir()]
    again = sorted(i for i in set(starts) if i != held and starts.count(i) > 1)
    assert again == [], f"runs {again} ran again after their worker died (it had done {earlier})"
    assert starts.count(held) == 2


@pytest.mark.slow
def test_run_that_kills_every_worker_is_an_error(mission, cluster, tmp_path):
    markers = tmp_path / "markers"
    markers.mkdir()
    plan = plan_campaign(
        mission, "pool_clear", 5, 4, overrides={"sleep_s": 0.05, "marker_dir": str(markers), "die_on": [2]}
    )
    records = execute(plan, slow_run, address=cluster.scheduler_address)
    assert [r.index for r in records] == list(range(5))
    assert records[2].outcome == "error" and "worker process died" in records[2].error
    assert "KilledWorker" in records[2].error
    assert len([m for m in markers.iterdir() if m.name.startswith("2.")]) == 2  # first try + the rerun alone
    # runs queued on the dying workers were blamed too, rerun, and succeeded
    assert all(r.outcome == "success" for i, r in enumerate(records) if i != 2), [r.error for r in records]


@pytest.mark.slow
def test_wall_clock_limit_on_the_cluster(mission, cluster):
    """On Dask the limit is checked inside the run (cooperatively)."""
    plan = plan_campaign(mission, "pool_clear", 3, 5, overrides={"sleep_s": 60.0}, timeout_s=0.3)
    records = execute(plan, slow_run, address=cluster.scheduler_address)
    assert [r.index for r in records] == [0, 1, 2]
    assert all(r.outcome == "error" and "wall-clock limit of 0.3 s" in r.error for r in records)


def test_wall_clock_limit_stops_a_hung_local_run(mission, tmp_path):
    """Local worker processes run the run in their main thread: SIGALRM stops
    even a run that never checks its deadline."""
    plan = plan_campaign(mission, "pool_clear", 2, 5, timeout_s=0.3)
    records = execute(plan, hanging_run, workers=2)
    assert [r.index for r in records] == [0, 1]
    assert all(r.outcome == "error" and r.error.startswith("RunTimeout: run exceeded") for r in records)


def test_cluster_with_threaded_workers_is_refused(mission):
    with distributed.LocalCluster(
        n_workers=1, threads_per_worker=2, processes=False, protocol="tcp", host="127.0.0.1", dashboard_address=None
    ) as c:
        with pytest.raises(ClusterError, match="--nthreads 1"):
            execute(plan_campaign(mission, "pool_clear", 1, 1), slow_run, address=c.scheduler_address)


@pytest.mark.slow
def test_workers_that_cannot_read_the_mission_are_refused(cluster, tmp_path):
    plan = plan_campaign("no/such/dir/mission.yaml", "pool_clear", 2, 1)
    with pytest.raises(ClusterError, match="cannot read no/such/dir/mission.yaml .working directory"):
        execute(plan, slow_run, address=cluster.scheduler_address)


@pytest.mark.slow
def test_unreachable_scheduler_is_a_clear_cli_error(monkeypatch, tmp_path, capsys):
    from mission.cli import main

    monkeypatch.setattr(cluster_mod, "CONNECT_TIMEOUT_S", 1.0)
    mission = os.path.join(os.path.dirname(__file__), "..", "..", "missions", "maris_pipe_recovery.yaml")
    rc = main(
        [
            "campaign",
            mission,
            "--scenario",
            "pool_clear",
            "--runs",
            "2",
            "--out",
            str(tmp_path / "out"),
            "--address",
            "tcp://127.0.0.1:9",
            "--quiet",
        ]
    )
    assert rc == 2
    err = capsys.readouterr().err
    assert "cannot reach the Dask scheduler at tcp://127.0.0.1:9" in err and "Traceback" not in err
