"""Real campaigns: the reference mission on the simulator through `maris campaign`.

The mission is a few seconds of survey (succeeds when the pipe is seen in
time, else the survey times out: not detected), so each run is short;
everything else (runtime, simulator, KCL, worker processes) is the real thing.
Logs are read back with the mcap package's own reader.
"""

import csv
import json
from dataclasses import replace
from pathlib import Path

import pytest

from mission.campaign.executor import execute
from mission.campaign.plan import plan_campaign
from mission.campaign.records import OUTCOMES
from mission.campaign.report import format_table
from mission.cli import main
from mission.runtime.options import RunHooks, RunOptions, RunTarget

SHORT_SURVEY = """\
version: 1
name: short_survey
description: A few seconds of survey; succeeds if the pipe is seen in time.
rates: {tree_hz: 10, vehicle_hz: 10, arm_hz: 100}
safety:
  max_depth_m: 10.0
  min_altitude_m: 0.5
  max_duration_s: 60
  geofence: {north_m: [-30, 30], east_m: [-30, 30], down_m: [0, 10]}
blackboard:
  target_pose: {type: pose}
tree:
  action:
    name: Survey until the pipe is seen
    run: survey
    targets:
      waypoints:
        - {north_m: 14.0, east_m: 6.0, altitude_m: 2.0, yaw_deg: 0}
    until: {detected: {min_confidence: 0.6, max_age_s: 0.5, store_as: target_pose}}
    timeout_s: 3
abort:
  action: {name: Hold still, run: hold, until: converged, timeout_s: 2}
"""


@pytest.fixture(scope="module")
def short_mission(tmp_path_factory) -> str:
    path = tmp_path_factory.mktemp("mission") / "short_survey.yaml"
    path.write_text(SHORT_SURVEY)
    return str(path)


def _campaign(mission, out, *extra):
    rc = main(
        [
            "campaign",
            mission,
            "--scenario",
            "pool_clear",
            "--runs",
            "5",
            "--workers",
            "2",
            "--seed",
            "5",
            "--out",
            str(out),
            "--quiet",
            *extra,
        ]
    )
    assert rc == 0
    return (out / "campaign.csv").read_text(), (out / "summary.txt").read_text()


def _mcap_result(path: Path) -> dict:
    from mcap.reader import make_reader

    with path.open("rb") as f:
        results = [json.loads(m.data) for _s, ch, m in make_reader(f).iter_messages(topics=["/run/result"])]
    assert len(results) == 1
    return results[0]


@pytest.mark.slow
def test_same_seed_same_table_and_logs(short_mission, tmp_path, capsys):
    csv1, table1 = _campaign(short_mission, tmp_path / "a", "--logs")
    # both with logs: the runtime's min_tool_to_target_m metric is sampled at the log rate
    csv2, table2 = _campaign(short_mission, tmp_path / "b", "--logs", "--workers", "1")
    printed = capsys.readouterr().out
    assert "success rate:" in printed and "wrote" in printed
    assert table1 == table2 and "5 runs, seed 5" in table1
    rows1 = list(csv.DictReader(csv1.splitlines()))
    rows2 = list(csv.DictReader(csv2.splitlines()))
    strip = lambda rows: [{k: v for k, v in r.items() if k != "log_path"} for r in rows]  # noqa: E731
    assert strip(rows1) == strip(rows2)
    assert [r["index"] for r in rows1] == [str(i) for i in range(5)]
    assert all(r["outcome"] in OUTCOMES and r["outcome"] != "error" for r in rows1)
    assert len({r["seed"] for r in rows1}) == 5
    assert (tmp_path / "a" / "campaign.png").stat().st_size > 5000
    for row in rows1:  # each run's log agrees with its CSV row
        log = Path(row["log_path"])
        assert log.parent == tmp_path / "a" / "logs"
        res = _mcap_result(log)
        assert float(row["duration_s"]) == pytest.approx(res["duration_s"], abs=1e-6)
        assert (row["failure_cause"] or None) == res["failure_cause"]


def test_failing_run_is_reported(short_mission, tmp_path):
    plan = plan_campaign(short_mission, "pool_clear", 3, 9)
    specs = list(plan.runs)
    specs[1] = replace(specs[1], mission_path=str(tmp_path / "deleted.yaml"))
    records = execute(specs, workers=2)
    assert [r.index for r in records] == [0, 1, 2]
    bad = records[1]
    assert bad.outcome == "error" and "deleted.yaml" in bad.error and "Traceback" in bad.traceback
    assert records[0].outcome != "error" and records[2].outcome != "error"
    table = format_table(records)
    assert "run 1 (seed" in table and "/3 = " in table
    assert [ln.split() for ln in table.splitlines() if ln.startswith("error")] == [["error", "1", "33.3", "%"]]


@pytest.mark.slow
def test_cluster_gives_the_same_records_as_local(short_mission):
    distributed = pytest.importorskip("distributed")
    plan = plan_campaign(short_mission, "pool_clear", 2, 21)
    local = execute(plan, workers=2)
    # one single-threaded worker: runs in one process must not overlap (py_trees' blackboard is per process)
    with distributed.LocalCluster(
        n_workers=1, threads_per_worker=1, processes=False, protocol="tcp", host="127.0.0.1", dashboard_address=None
    ) as cluster:
        remote = execute(plan, address=cluster.scheduler_address)
    key = lambda rs: [(r.index, r.seed, r.outcome, r.duration_s, r.failure_cause, r.metrics) for r in rs]  # noqa: E731
    assert key(remote) == key(local)
    assert all(r.outcome != "error" for r in remote)


def test_arm_reference_recorder_sees_every_arm_step(short_mission):
    import math

    from mission.campaign.single import ArmReferenceRecorder, run_one
    from mission.runtime.api import run_mission

    rec = ArmReferenceRecorder()
    # very turbid water: the survey runs its full 3 s without seeing the pipe
    result = run_mission(
        RunTarget(short_mission, scenario="pool_clear", seed=4, overrides={"vision.turbidity": "very_turbid"}),
        RunOptions(),
        RunHooks(on_supervisor=rec.attach, on_progress=rec.on_progress),
    )
    assert len(rec.t) > 100 and len(rec.qdot) == len(rec.t)
    assert all(b - a == pytest.approx(0.01, abs=1e-9) for a, b in zip(rec.t, rec.t[1:]) if b - a < 0.05)
    assert "survey" in rec.action
    assert math.isfinite(rec.oscillation("survey")) and math.isnan(rec.oscillation("grasp"))
    assert result.duration_s > 0
    spec = plan_campaign(short_mission, "pool_clear", 1, 4, measure=("oscillation",)).runs[0]
    assert math.isnan(run_one(spec).metrics["grasp_osc_rms_rad_s"])  # this mission never grasps
