"""The real-time process options of ``maris run`` (--rt-priority, --nice, --rt-affinity, --lock-memory,
--gil-interval, --gc) and the loop's timing records (mission/runtime/rtprocess.py,
steptiming.py). No durations are asserted: only what was applied and counted."""

from __future__ import annotations

import gc
import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from mission.runtime.rtprocess import GcControl, ProcessSettings, apply_process_settings, current_settings, parse_cpus
from mission.runtime.steptiming import StepTimes

pytestmark = pytest.mark.realtime  # scheduling settings of live processes

ROOT = Path(__file__).resolve().parents[2]

MISSION = """\
version: 1
name: short_hold
rates: {tree_hz: 10, vehicle_hz: 10, arm_hz: 100}
safety:
  max_depth_m: 10.0
  min_altitude_m: 0.3
  max_duration_s: 30
  geofence: {north_m: [-30, 30], east_m: [-30, 30], down_m: [0, 10]}
blackboard:
  never: {type: bool}
tree:
  parallel:
    policy: success_on_one
    children:
      - action: {name: Hold, run: hold, until: {blackboard: {key: never, equals: true}}, timeout_s: 20}
      - wait: {duration_s: 0.5}
abort:
  action: {name: Hold still, run: hold, timeout_s: 0.5}
"""


def maris_run(tmp_path: Path, *options: str) -> subprocess.CompletedProcess:
    mission = tmp_path / "short_hold.yaml"
    mission.write_text(MISSION)
    cmd = [
        sys.executable,
        "-m",
        "mission.cli",
        "run",
        str(mission),
        "--hal",
        str(ROOT / "hal" / "configs" / "sim.yaml"),
        "--json",
        "--log",
        str(tmp_path / "run.mcap"),
        *options,
    ]
    return subprocess.run(cmd, cwd=ROOT, capture_output=True, text=True, timeout=120)


def test_parse_cpus() -> None:
    assert parse_cpus("1") == {1} and parse_cpus("0,2") == {0, 2} and parse_cpus("0-3") == {0, 1, 2, 3}
    assert parse_cpus(" 0 , 2-3 ") == {0, 2, 3}
    for bad in ("", "a", "1-", "3-1", "-1", ","):
        with pytest.raises(ValueError):
            parse_cpus(bad)


def test_applying_the_current_settings_reports_them() -> None:
    # the same CPUs and niceness this process has already: applied for real, nothing changes
    now = current_settings()
    applied = apply_process_settings(ProcessSettings(cpus=frozenset(os.sched_getaffinity(0)), nice=now["nice"]))
    assert applied["cpus"] == sorted(os.sched_getaffinity(0)) and applied["nice"] == now["nice"]
    assert ProcessSettings().empty and not ProcessSettings(nice=1).empty


@pytest.mark.slow
def test_gc_manual_disables_the_collector_in_the_loop_and_restores_it() -> None:
    assert gc.isenabled()
    control = GcControl("manual")
    control.start()
    try:
        assert not gc.isenabled() and gc.get_freeze_count() > 0
        control.tick()
        control.tick()
    finally:
        control.stop()
    assert gc.isenabled() and gc.get_freeze_count() == 0
    summary = control.summary()
    assert summary["mode"] == "manual" and summary["collections"] == 2 and summary["by_generation"]["0"] == 2
    gc.collect()  # after stop: no longer counted
    assert control.summary()["collections"] == 2
    with pytest.raises(ValueError, match="gc mode"):
        GcControl("sometimes")


def test_gc_freeze_keeps_the_automatic_collector() -> None:
    control = GcControl("freeze")
    control.start()
    try:
        assert gc.isenabled() and gc.get_freeze_count() > 0 and not control.manual
        gc.collect(0)
    finally:
        control.stop()
    assert gc.get_freeze_count() == 0 and control.summary()["collections"] == 1


def test_latency_counts_each_reading_once_at_its_first_command() -> None:
    times = StepTimes()
    times.command_sent(1.004, nav_t=1.000, js_t=0.998)
    times.command_sent(1.014, nav_t=1.000, js_t=1.009)  # same attitude reading: not counted again
    times.command_sent(1.024, nav_t=float("nan"), js_t=1.009)  # no reading at all: nothing
    lat = times.latency_summary(t0=0.5)
    assert lat["ahrs"]["n"] == 1 and lat["ahrs"]["max_s"] == pytest.approx(0.004)
    assert lat["joints"]["n"] == 2 and lat["joints"]["max_s"] == pytest.approx(0.006)
    assert lat["ahrs"]["max_at_s"] == pytest.approx(0.5) and lat["joints"]["max_at_s"] == pytest.approx(0.498)
    assert StepTimes().latency_summary()["ahrs"]["max_at_s"] is None
    later = StepTimes()
    later.count_from_t = 1.000  # the loop's first step: readings before it waited for the engagement
    later.command_sent(1.004, nav_t=0.950, js_t=0.990)
    later.command_sent(1.014, nav_t=1.010, js_t=0.990)
    lat = later.latency_summary()
    assert lat["ahrs"]["n"] == 1 and lat["ahrs"]["max_s"] == pytest.approx(0.004) and lat["joints"]["n"] == 0
    times.work.extend([0.001, 0.002, 0.02])
    work = times.summary(0.01)
    assert work["steps"] == 3 and work["over_period"] == 1 and work["max_s"] == pytest.approx(0.02)


@pytest.mark.slow
def test_maris_run_applies_the_process_options(tmp_path: Path) -> None:
    proc = maris_run(tmp_path, "--rt-affinity", "0", "--nice", "3", "--gil-interval", "1", "--gc", "manual")
    assert proc.returncode == 0, proc.stderr
    metrics = json.loads(proc.stdout)["metrics"]
    assert metrics["wall_process"]["cpus"] == [0] and metrics["wall_process"]["nice"] == 3
    assert metrics["wall_process"]["gil_interval_s"] == pytest.approx(0.001)
    gcs = metrics["wall_gc"]
    assert gcs["mode"] == "manual" and gcs["collections"] >= 1 and gcs["by_generation"]["2"] == 0
    work = metrics["wall_step_work"]
    assert work["steps"] == metrics["steps"] and work["p50_s"] <= work["p99_s"] <= work["max_s"]


@pytest.mark.parametrize(
    ("options", "message"),
    [
        (("--rt-affinity", "4096"), "--rt-affinity: no CPU [4096]"),
        (("--rt-affinity", "one"), "expected CPU numbers"),
        (("--nice", "40"), "--nice must be in -20..19"),
        (("--rt-priority", "0"), "--rt-priority must be in 1.."),
        (("--gil-interval", "0"), "--gil-interval must be"),
    ],
)
def test_maris_run_refuses_bad_process_options(tmp_path: Path, options: tuple[str, ...], message: str) -> None:
    proc = maris_run(tmp_path, *options)
    assert proc.returncode == 2 and message in proc.stderr and "Traceback" not in proc.stderr
    assert not (tmp_path / "run.mcap").exists()  # refused before anything ran


PUT_LOOP_FIRST = """
import json, os, threading, time
from mission.runtime.rtprocess import ProcessSettings, apply_process_settings, current_settings, put_loop_first
print(json.dumps({"before": put_loop_first()}))  # not under SCHED_FIFO: nothing done
apply_process_settings(ProcessSettings(rt_priority=10, lock_memory=True))
ids = []
ready, stop = threading.Event(), threading.Event()
def driver():
    ids.append(threading.get_native_id())
    ready.set()
    stop.wait(10)
t = threading.Thread(target=driver)
t.start()
ready.wait(10)
moved = put_loop_first()
print(json.dumps({"moved": moved, "loop": os.sched_getparam(0).sched_priority,
                  "driver": os.sched_getparam(ids[0]).sched_priority, "locked": current_settings()["memory_locked"]}))
stop.set()
t.join()
"""


def test_the_loop_is_put_one_priority_above_its_threads() -> None:
    """Under SCHED_FIFO the other threads go one priority below the loop's, and the
    memory lock is applied (both need root or capabilities: skipped without)."""
    proc = subprocess.run([sys.executable, "-c", PUT_LOOP_FIRST], cwd=ROOT, capture_output=True, text=True, timeout=60)
    if "ProcessSettingError" in proc.stderr or "Operation not permitted" in proc.stderr:
        pytest.skip("SCHED_FIFO or mlockall not permitted here")
    assert proc.returncode == 0, proc.stderr
    before, after = (json.loads(line) for line in proc.stdout.splitlines())
    assert before == {"before": None}
    assert after["moved"] == {"loop": 10, "others": 9, "threads": 1}
    assert after["loop"] == 10 and after["driver"] == 9 and after["locked"] is True


def test_a_refused_memory_lock_says_why_and_what_to_do(monkeypatch) -> None:
    """mlockall refused (as for an unprivileged user: root here cannot be refused, so
    the C library's answer is stood in for): a ProcessSettingError with the OS's
    reason and the fix, which maris run prints as an error (exit 2, see above)."""
    import ctypes
    import errno

    from mission.runtime import rtprocess

    class RefusingLibc:
        def mlockall(self, flags: int) -> int:
            ctypes.set_errno(errno.EPERM)
            return -1

    monkeypatch.setattr(ctypes, "CDLL", lambda *a, **k: RefusingLibc())
    with pytest.raises(
        rtprocess.ProcessSettingError, match=r"--lock-memory: mlockall refused \(Operation not permitted\).*ulimit -l"
    ):
        rtprocess.lock_memory()
