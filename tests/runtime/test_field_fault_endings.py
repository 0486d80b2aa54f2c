"""The fault table (docs/faults.md) on the real drivers: runs of a short mission
on a real backend whose devices are protocol peers in other processes (CiA 402
drives on host-only CAN, an ArduSub-like MAVLink peer, a Water Linked DVL over
TCP, a MicroStrain AHRS on a pseudo-terminal, a Ping echosounder over UDP). Each
fault is injected while the mission runs and must end the run as the table says;
a device not heard at the start refuses the start unless the operator allows it."""

from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path

import pytest

from hal.config import load_hal_config
from hal.factory import build_backend
from hal.testing.field_rig import FieldRig
from hal.testing.peers import ROOT, free_tcp_port, peer_report, wait_until
from mission.logs.reader import read_log
from mission.runtime.api import run_mission
from mission.runtime.options import RunHooks, RunOptions, RunTarget
from mission.runtime.result import SupervisorOptions
from mission.runtime.safety import FAULT_TABLE, classify_health

MISSION = """\
version: 1
name: hold_station
rates: {tree_hz: 10, vehicle_hz: 10, arm_hz: 100}
safety:
  max_depth_m: 10.0
  min_altitude_m: 0.5
  max_duration_s: 60
  geofence: {north_m: [-30, 30], east_m: [-30, 30], down_m: [0, 10]}
  watchdog_s: {navigation: 0.3, joints: 0.5}
blackboard:
  done: {type: bool}
tree:
  action: {name: Hold, run: hold, timeout_s: 4, until: {blackboard: {key: done, equals: true}}}
abort:
  action: {name: Hold still, run: hold, timeout_s: 1.5, until: {blackboard: {key: done, equals: true}}}
"""


@pytest.fixture(scope="module")
def field(tmp_path_factory):  # noqa: ANN201
    """Peers for a whole field setup and its HAL config (shared by the runs of this module)."""
    tmp = tmp_path_factory.mktemp("field")
    rig = FieldRig.start(ping=True)
    cfg = rig.write_config(tmp / "hal.yaml")
    mission = tmp / "hold.yaml"
    mission.write_text(MISSION)
    yield {"peers": rig.peers, "config": load_hal_config(cfg), "mission": mission, "tmp": tmp}
    rig.stop()


def run(field, name: str, inject=None, *, config=None, finish_after=None, **options):  # noqa: ANN001, ANN201
    """One run; ``inject(supervisor)`` is called once, 1 s after the mission started
    running (drives enabled, vehicle armed); ``finish_after`` s after that start the
    mission is told it is done (it succeeds). ``config``: another HAL config than the rig's."""
    config = config or field["config"]
    backend = build_backend(config)
    fired = []

    def poll(now: float) -> None:
        sup = state["sup"]
        if sup.lifecycle.state != "running":
            return
        started = state.setdefault("running_since", now)  # preflight's length varies with the machine's load
        if inject is not None and not fired and now - started > 1.0:
            fired.append(now)
            inject(sup)
        if finish_after is not None and now - started > finish_after:
            sup.ctx.blackboard.set("done", True)

    state: dict = {}
    log_path = field["tmp"] / f"{name}.mcap"
    options.setdefault("realtime_preflight_timeout_s", 10.0)  # ends as soon as all is ready
    opts = SupervisorOptions(settle_s=0.3, **options)
    result = run_mission(
        RunTarget(field["mission"], backend=backend, hal_config=config),
        RunOptions(log_path=log_path, supervisor=opts),
        RunHooks(pollers=[poll], on_supervisor=lambda s: state.update(sup=s)),
    )
    return result, read_log(log_path), fired


def kinds(log) -> list[tuple[str, str]]:  # noqa: ANN001
    return [(m["kind"], m["message"]) for m in log.messages("/events")]


@pytest.mark.peer
@pytest.mark.slow
def test_dvl_loss_runs_the_abort_path(field) -> None:  # noqa: ANN001
    dvl = field["peers"]["dvl"]
    result, log, fired = run(field, "dvl", lambda _: dvl.send(cmd="silence"))
    dvl.send(cmd="resume")
    assert fired and result.outcome == "aborted", result.failure_cause
    assert result.failure_cause.startswith("watchdog (dvl_velocity)")
    ev = kinds(log)
    assert any(k == "abort_path" and "running the mission's abort path" in m for k, m in ev)
    start = next(m for m in log.messages("/events") if m["kind"] == "abort_path")
    end = next(m for m in log.messages("/events") if m["kind"] == "abort")
    assert (
        end["message"] == "abort path ended: FAILURE" and end["t"] - start["t"] > 1.4
    )  # ran whole, to its own timeout
    lost = [m for m in log.messages("/events") if m["kind"] == "sensor_lost"]
    assert lost and lost[0]["level"] == "warning" and lost[0]["message"].startswith("dvl fault: DVL:")


@pytest.mark.peer
@pytest.mark.slow
def test_ping_loss_is_a_warning_and_the_run_goes_on(field) -> None:  # noqa: ANN001
    """The Ping stops answering mid-run: `sensor_lost (ping)`, ending `warn` (logged once as a
    warning), the vehicle's altitude from the DVL; the mission ends as it would have."""
    ping = field["peers"]["ping"]
    result, log, fired = run(field, "ping", lambda _: ping.send(cmd="stall"), finish_after=2.5)
    ping.send(cmd="resume")
    assert fired and result.outcome == "succeeded", result.failure_cause
    lost = [m for m in log.messages("/events") if m["kind"] == "sensor_lost"]
    assert len(lost) == 1 and lost[0]["level"] == "warning", lost
    assert lost[0]["message"].startswith("ping fault: Ping echosounder: lost: silent for"), lost[0]["message"]
    assert lost[0]["t"] > fired[0] and lost[0]["fields"]["ending"] == "warn"
    assert not any(m["kind"] == "abort_path" for m in log.messages("/events"))


def without_dvl_server(field, name: str) -> tuple[Path, str]:  # noqa: ANN001
    """The rig's HAL config with the DVL on a 127.0.0.1 port nobody serves, and the
    ``file:line:column`` of its `dvl` entry."""
    text = Path(field["config"].path).read_text()
    dvl_port = int(field["peers"]["dvl"].ready)
    text = text.replace(f"port: {dvl_port},", f"port: {free_tcp_port()},")
    path = field["tmp"] / name
    path.write_text(text)
    line, col = next((i, ln.index("{") + 1) for i, ln in enumerate(text.splitlines(), 1) if ln.startswith("    dvl:"))
    return path, f"{path}:{line}:{col}: devices.vehicle.dvl"


@pytest.mark.peer
@pytest.mark.slow
def test_a_dvl_nobody_serves_refuses_the_start_unless_the_operator_allows_it(field) -> None:  # noqa: ANN001
    path, entry = without_dvl_server(field, "no_dvl.yaml")
    config = load_hal_config(path)
    result, log, _ = run(field, "no_dvl", config=config, realtime_preflight_timeout_s=3.0)
    assert result.outcome == "failed" and result.failure_cause.startswith("preflight: "), result.failure_cause
    assert (
        "dvl not heard since the start (DVL: cannot open 127.0.0.1:" in result.failure_cause
        and f"configured at {entry}): start without it with --allow-missing dvl" in result.failure_cause
    ), result.failure_cause
    assert not any(m["kind"] == "engage" for m in log.messages("/events"))
    assert peer_report(field["peers"]["mav"])["armed"] is False
    # allowed: the run starts, says so once, and the DVL's absence is the fault table's warning
    result, log, _ = run(field, "no_dvl_allowed", config=config, allow_missing=("dvl",), finish_after=1.0)
    assert result.outcome == "succeeded", result.failure_cause
    allowed = [m for m in log.messages("/events") if m["kind"] == "allowed_missing"]
    assert len(allowed) == 1 and allowed[0]["level"] == "warning", allowed
    assert allowed[0]["message"].startswith("dvl not heard since the start (DVL: cannot open")
    assert f"configured at {entry}): starting without it, as the operator allowed" in allowed[0]["message"]
    assert any(m["kind"] == "engage" for m in log.messages("/events"))


WAIT_MISSION = """\
version: 1
name: wait_a_moment
rates: {tree_hz: 10, vehicle_hz: 10, arm_hz: 100}
safety:
  max_depth_m: 10.0
  min_altitude_m: 0.5
  max_duration_s: 30
  geofence: {north_m: [-30, 30], east_m: [-30, 30], down_m: [0, 10]}
tree:
  wait: {name: Wait, duration_s: 1.0}
abort:
  wait: {name: Still, duration_s: 0.5}
"""


def maris(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run(
        [sys.executable, "-m", "mission.cli", *args], cwd=ROOT, capture_output=True, text=True, timeout=90
    )


@pytest.mark.peer
@pytest.mark.slow
def test_maris_hal_check_and_run_name_the_device_not_heard(field) -> None:  # noqa: ANN001
    path, entry = without_dvl_server(field, "no_dvl_cli.yaml")
    check = maris("hal", "check", str(path), "--wait", "1")
    assert check.returncode == 1, check.stdout + check.stderr
    assert f"not heard since the start: dvl ({entry}): DVL: cannot open 127.0.0.1:" in check.stdout, check.stdout
    assert "`maris run` refuses to start without dvl unless told: --allow-missing dvl" in check.stdout
    mission = field["tmp"] / "wait.yaml"
    mission.write_text(WAIT_MISSION)
    bad = maris(
        "run", str(mission), "--hal", str(path), "--allow-missing", "dvl,sonar", "--log", str(field["tmp"] / "bad.mcap")
    )
    assert bad.returncode == 2 and "--allow-missing sonar: not a device of" in bad.stderr, bad.stderr
    assert "(those are: dvl, ahrs, ping;" in bad.stderr
    log_path = field["tmp"] / "wait.mcap"
    ok = maris("run", str(mission), "--hal", str(path), "--allow-missing", "dvl", "--log", str(log_path))
    assert ok.returncode == 0, ok.stdout + ok.stderr
    assert "allowed_missing: dvl not heard since the start" in ok.stdout, ok.stdout
    events = [m for m in read_log(log_path).messages("/events") if m["kind"] == "allowed_missing"]
    assert len(events) == 1 and entry in events[0]["message"]


@pytest.mark.peer
@pytest.mark.slow
def test_ahrs_loss_runs_the_abort_path_cut_short(field) -> None:  # noqa: ANN001
    ahrs = field["peers"]["ahrs"]
    result, log, fired = run(field, "ahrs", lambda _: ahrs.send(cmd="silence"), short_abort_s=0.4)
    ahrs.send(cmd="resume")
    assert fired and result.outcome == "aborted", result.failure_cause
    assert re.match(r"(sensor_lost \(ahrs\)|watchdog \(navigation\))", result.failure_cause), result.failure_cause
    ev = kinds(log)
    assert any(k == "abort_path" and m.startswith("abort path cut short to 0.4 s") for k, m in ev), ev
    end = next(m for m in log.messages("/events") if m["kind"] == "abort")
    start = next(m for m in log.messages("/events") if m["kind"] == "abort_path")
    assert end["message"].startswith("abort path timed out") and end["t"] - start["t"] < 0.8


@pytest.mark.peer
@pytest.mark.slow
def test_arm_drive_fault_stops_at_once_and_the_next_run_resets_it_on_request(field) -> None:  # noqa: ANN001
    can = field["peers"]["can"]
    result, log, fired = run(field, "drive", lambda _: can.send(cmd="fault", node=3, code=0x2310))
    assert fired and result.outcome == "aborted", (result.outcome, result.failure_cause)
    assert result.failure_cause.startswith("drive_fault (arm): ")
    assert (
        "arm joint j3_upper_arm_roll (node 3): CiA 402 FAULT, EMCY 0x2310 (continuous over-current), "
        "error register 0x03 (generic, current)"
    ) in result.failure_cause
    ev = kinds(log)
    assert not any(k == "abort_path" for k, _ in ev)
    assert [m for k, m in ev if k == "abort"][0].startswith("safe stop without abort path: drive_fault (arm)")
    assert sum(1 for k, _ in ev if k == "drive_fault") == 1  # one joint fault, logged once
    # the drive is still faulted: the next run refuses to start, naming the fault and the reset
    result, log, _ = run(field, "drive_again", realtime_preflight_timeout_s=2.0)
    assert result.outcome == "failed" and result.failure_cause.startswith("preflight: "), result.failure_cause
    assert "arm fault: " in result.failure_cause, result.failure_cause
    assert "EMCY 0x2310 (continuous over-current)" in result.failure_cause and "--reset-faults" in result.failure_cause
    assert not any(m["kind"] == "engage" for m in log.messages("/events"))
    result, log, _ = run(field, "drive_reset", lambda sup: sup.ctx.blackboard.set("done", True), reset_faults=True)
    resets = [m for m in log.messages("/events") if m["kind"] == "fault_reset"]
    assert len(resets) == 1 and "node 3" in resets[0]["message"] and "EMCY 0x2310" in resets[0]["message"]
    assert result.outcome == "succeeded", result.failure_cause
    assert not any(log.messages("/vehicle/command")[-1]["body_velocity"])  # the log ends on the final zero commands
    assert not any(log.messages("/arm/command")[-1]["velocity"])


@pytest.mark.peer
@pytest.mark.slow
def test_link_and_gripper_faults_of_the_real_drivers_classify_as_the_table_says(field) -> None:  # noqa: ANN001
    """The real vehicle's and gripper's health, faulted by their peers, against FAULT_TABLE."""
    backend = build_backend(field["config"])
    backend.open()
    try:
        devs = backend.devices
        assert wait_until(lambda: all(d.health().state.usable for d in devs.by_role().values()), 10.0)
        field["peers"]["mav"].send(cmd="silence")
        field["peers"]["can"].send(cmd="fault", node=11, code=0x7121)
        assert wait_until(
            lambda: not devs.vehicle.health().state.usable and not devs.gripper.health().state.usable, 6.0
        )
        vehicle = classify_health("vehicle", devs.vehicle.health())
        assert [(b.kind, b.source, b.ending) for b in vehicle] == [("vehicle_link", "vehicle", "stop")]
        gripper = classify_health("gripper", devs.gripper.health())
        assert [(b.kind, b.ending) for b in gripper] == [("gripper_fault", "leaf")]
        assert "EMCY 0x7121 (motor blocked)" in gripper[0].message
    finally:
        field["peers"]["mav"].send(cmd="resume")
        devs.gripper.reset_faults()
        backend.close()


def test_docs_fault_table_matches_the_code() -> None:
    """docs/faults.md's table rows (kind, source, ending) are exactly FAULT_TABLE's."""
    text = (Path(ROOT) / "docs" / "faults.md").read_text()
    rows = re.findall(r"^\| `([a-z_]+)` \| `([a-z_*]+)` \| [^|]+ \| `([a-z_]+)` \|", text, re.M)
    assert {(k, s): e for k, s, e in rows} == FAULT_TABLE
