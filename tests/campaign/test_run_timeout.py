"""The per-run wall-clock limit with the real run function (runtime, simulator,
KCL): a run past it is an `error` record, locally (SIGALRM in the worker's main
thread) and on a Dask worker thread (checked at the supervisor's tree ticks)."""

import pytest

from mission.campaign.executor import execute
from mission.campaign.plan import plan_campaign

LONG_SURVEY = """\
version: 1
name: long_survey
description: A survey far longer than the wall-clock limits of these tests.
rates: {tree_hz: 10, vehicle_hz: 10, arm_hz: 100}
safety:
  max_depth_m: 10.0
  min_altitude_m: 0.5
  max_duration_s: 600
  geofence: {north_m: [-30, 30], east_m: [-30, 30], down_m: [0, 10]}
tree:
  action:
    name: Survey
    run: survey
    targets:
      waypoints:
        - {north_m: 25.0, east_m: 25.0, altitude_m: 2.0, yaw_deg: 0}
    timeout_s: 500
abort:
  action: {name: Hold still, run: hold, until: converged, timeout_s: 2}
"""


@pytest.fixture(scope="module")
def long_mission(tmp_path_factory) -> str:
    path = tmp_path_factory.mktemp("mission") / "long_survey.yaml"
    path.write_text(LONG_SURVEY)
    return str(path)


def test_the_mission_is_valid(long_mission):
    from mission.loader import load_mission

    load_mission(long_mission)  # (else the runs below would fail for another reason)


@pytest.mark.slow
def test_local_run_past_its_limit_is_an_error(long_mission):
    records = execute(plan_campaign(long_mission, "pool_clear", 1, 3, timeout_s=1.5), workers=1)
    assert records[0].outcome == "error"
    assert "RunTimeout: run exceeded its wall-clock limit of 1.5 s" in records[0].error
    assert records[0].wall_s < 60


@pytest.mark.slow
def test_cluster_run_past_its_limit_is_an_error(long_mission):
    distributed = pytest.importorskip("distributed")
    with distributed.LocalCluster(
        n_workers=1, threads_per_worker=1, processes=False, protocol="tcp", host="127.0.0.1", dashboard_address=None
    ) as cluster:
        records = execute(
            plan_campaign(long_mission, "pool_clear", 1, 3, timeout_s=1.5), address=cluster.scheduler_address
        )
    assert records[0].outcome == "error"
    assert "RunTimeout: run exceeded its wall-clock limit of 1.5 s" in records[0].error
    assert records[0].wall_s < 60


def test_cli_refuses_a_negative_limit(long_mission, tmp_path, capsys):
    from mission.cli import main

    rc = main(
        [
            "campaign",
            long_mission,
            "--scenario",
            "pool_clear",
            "--run-timeout",
            "-1",
            "--out",
            str(tmp_path / "out"),
            "--quiet",
        ]
    )
    assert rc == 2
    assert "--run-timeout must be >= 0 seconds" in capsys.readouterr().err
