"""The field loop in real time: ``maris run`` against the protocol peers, with logging on.

Starts the peers of a whole field setup in other processes (ten CiA 402 drives
on host-only CAN: python-can ``udp_multicast`` on 239.74.163.2 with hop_limit
0; an ArduSub-like MAVLink vehicle on 127.0.0.1 TCP; a Water Linked DVL on TCP
at 10 Hz; a MicroStrain AHRS on a pseudo-terminal at 50 Hz), writes their HAL
config and a mission that holds station (the ``hold`` action: both KCL
optimizations run every step) for ``--duration`` s, and runs the real
command line, ``maris run MISSION --hal CONFIG --json --log ...``, as a
separate process. Optionally a CPU hog runs beside it the whole time
(``--hog busy``: one busy-looping process per CPU; ``--hog campaign``: a
``maris campaign`` of the reference mission with one worker per CPU). The
peers stand in for hardware, which does not share the vehicle computer's CPUs:
they run under SCHED_FIFO (``--peer-priority``, default 40, when permitted) so
the hog cannot starve them, when the run itself has ``--rt-priority`` (below
it); otherwise they stay at normal priority, so they do not preempt an
ordinary run (``--peer-priority`` sets it).

Prints what ``maris run`` measured on itself (``wall_*`` metrics, see
``mission/runtime/steptiming.py``):

* step work: wall time of each 10 ms base step up to its hand-over to the
  pacer (devices, safety, tree, both KCLs, commands, log), p50/p99/max; the
  log's flush every 0.5 s, made after a step's work, is apart (its own line;
  a flush that ran past the next tick would show as a deadline miss);
* deadline misses: ticks whose step (wake-up delay included) ended after the
  next tick's time (``missed``), the worst lateness, and the ticks more than a
  whole period behind (``overruns``, the grid re-anchored);
* wake-up lateness of the pacer (OS scheduling delay after each sleep);
* latency from a reading's arrival (AHRS attitude; joint positions) to the
  hand-over of the first command computed from it (p50/p99/max, and when
  the reading of the max arrived, s into the run; readings that arrived
  before the loop's first step, which waited for the engagement, are left
  out); the
  drivers' own send cadence (CANopen service thread every 10 ms, MAVLink
  setpoint stream) is after that and not included;
* garbage-collector pauses during the loop; the process settings it ran with;
* where the devices' health polls of the tree steps were computed: by the
  drivers' prefetch worker between the steps (the default), or on the loop
  thread (``--no-health-prefetch``, or the worker not done in time);
* the modules first imported inside the loop (``loop_imports``: each import
  reads and runs a module in the middle of a step; the aim is none);
* the five slowest steps, each with its largest phases and the loop thread's
  CPU time over it (a step that took much longer than its CPU time waited:
  another thread held the interpreter, or the OS ran something else);
* a control: the same fixed piece of pure-Python work every 10 ms in a
  process with the same settings beside the same hog, just before the run
  (the machine's own jitter, which no change in the loop can go below); and
  the same control beside the run for its whole length, whose stalls (an
  iteration over 2 ms) are set against the run's slowest steps: a step that
  overlapped one was (at least partly) the machine's;
* the CPU time of the ``maris run`` process, all its threads (the loop, the
  drivers' readers and service threads, the log writer), from start to exit.

    .venv/bin/python benchmarks/field_loop.py [--duration 180] [--hog none|busy|campaign]
        [--rt-priority N] [--nice N] [--rt-affinity CPUS] [--gil-interval MS] [--lock-memory] [--gc auto|freeze|manual]
        [--no-health-prefetch] [--actions FILE] [--keep DIR]

Target (issue 18): p99 work <= 2 ms per 10 ms step and no missed tick over
5 minutes with a hog. Last line, machine-readable:
``field_loop duration_s=.. hog=.. work_p50_ms=.. work_p99_ms=.. work_max_ms=.. missed=.. worst_late_ms=..
overruns=.. latency_ahrs_p50_ms=.. latency_ahrs_p99_ms=.. latency_joints_p99_ms=.. loop_imports=.. cpu_s=.. settings=..``
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import shutil
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from hal.testing.field_rig import FieldRig  # noqa: E402
from hal.testing.peers import Peer  # noqa: E402

MISSION = """\
version: 1
name: field_loop_hold
description: Hold station (both KCL optimizations every step) for {duration:g} s.
rates: {{tree_hz: 10, vehicle_hz: 10, arm_hz: 100}}
safety:
  max_depth_m: 10.0
  min_altitude_m: 0.5
  max_duration_s: {max_duration:g}
  geofence: {{north_m: [-30, 30], east_m: [-30, 30], down_m: [0, 10]}}
  watchdog_s: {{navigation: 0.3, joints: 0.5}}
blackboard:
  never: {{type: bool}}
tree:
  parallel:
    name: Hold for the benchmark
    policy: success_on_one
    children:
      - action: {{name: Hold, run: hold, until: {{blackboard: {{key: never, equals: true}}}}, timeout_s: {max_duration:g}}}
      - wait: {{duration_s: {duration:g}}}
abort:
  action: {{name: Hold still, run: hold, timeout_s: 1.5}}
"""


def shield_peers(peers: dict[str, Peer], priority: int) -> str:
    """Run every thread of the peers under SCHED_FIFO ``priority``: they stand in for
    hardware (drives, autopilot, DVL, AHRS), which does not share the vehicle computer's
    CPUs, so the hog must not starve them. Returns what was done (or why not)."""
    if priority <= 0:
        return "peers at normal priority (they compete with the hog)"
    try:
        for peer in peers.values():
            for tid in os.listdir(f"/proc/{peer.proc.pid}/task"):
                os.sched_setscheduler(int(tid), os.SCHED_FIFO, os.sched_param(priority))
    except (OSError, AttributeError) as exc:
        return f"peers at normal priority: SCHED_FIFO refused ({exc}); they compete with the hog"
    return f"peers under SCHED_FIFO {priority} (hardware stand-ins, out of the hog's reach)"


def start_hog(kind: str, procs: int, tmp: Path) -> subprocess.Popen | None:
    """The CPU hog beside the run, in its own process group (so it is ended whole)."""
    if kind == "none":
        return None
    if kind == "busy":
        code = (
            "import multiprocessing as m, sys\n"
            "def spin():\n    while True: pass\n"
            f"ps = [m.Process(target=spin, daemon=True) for _ in range({procs})]\n"
            "[p.start() for p in ps]\n[p.join() for p in ps]\n"
        )
        cmd = [sys.executable, "-c", code]
    else:
        cmd = [
            str(ROOT / ".venv" / "bin" / "maris"),
            "campaign",
            str(ROOT / "missions" / "maris_pipe_recovery.yaml"),
            "--scenario",
            "pool_clear",
            "--runs",
            "2000",
            "--workers",
            str(procs),
            "--out",
            str(tmp / "campaign"),
        ]
    return subprocess.Popen(cmd, cwd=ROOT, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, start_new_session=True)


def stop_hog(hog: subprocess.Popen | None) -> None:
    if hog is None:
        return
    try:
        os.killpg(hog.pid, signal.SIGKILL)  # the group this script started (the hog and its workers)
    except ProcessLookupError:
        pass
    hog.wait(timeout=10)


CONTROL = """
import json, os, sys, time
sys.path.insert(0, {root!r})
from mission.runtime.rtprocess import ProcessSettings, apply_process_settings, parse_cpus
apply_process_settings(ProcessSettings(rt_priority={prio!r}, nice={nice!r},
                                       cpus=None if {cpus!r} is None else parse_cpus({cpus!r})))
d = []
for _ in range(300):
    t = time.perf_counter()
    sum(range(25000))  # a fixed piece of pure-Python work, ~0.5 ms on an idle core
    d.append(time.perf_counter() - t)
    time.sleep(0.01)
d.sort()
print(json.dumps({{"p50_s": d[len(d) // 2], "p99_s": d[int(0.99 * len(d))], "max_s": d[-1]}}))
"""


#: The control beside the run, for its whole length: the same work every 10 ms until stdin closes;
#: prints its percentiles and every iteration over STALL_S (perf_counter start, duration).
CONTROL_DURING = """
import json, os, sys, threading, time
sys.path.insert(0, {root!r})
from mission.runtime.rtprocess import ProcessSettings, apply_process_settings, parse_cpus
apply_process_settings(ProcessSettings(rt_priority={prio!r}, nice={nice!r},
                                       cpus=None if {cpus!r} is None else parse_cpus({cpus!r})))
done = threading.Event()
threading.Thread(target=lambda: (sys.stdin.read(), done.set()), daemon=True).start()
d, stalls = [], []
while not done.is_set():
    t = time.perf_counter()
    sum(range(25000))
    w = time.perf_counter() - t
    d.append(w)
    if w > {stall!r} and len(stalls) < 5000:
        stalls.append((t, w))
    time.sleep(0.01)
d.sort()
print(json.dumps({{"n": len(d), "p50_s": d[len(d) // 2], "p99_s": d[int(0.99 * len(d))], "max_s": d[-1],
                  "stalls": stalls}}))
"""
#: A control iteration (~0.5 ms of work) longer than this is a stall of the machine (s).
STALL_S = 0.002


def start_control_during(args: argparse.Namespace) -> subprocess.Popen:
    """The control workload for the whole run (stopped by :func:`stop_control_during`)."""
    code = CONTROL_DURING.format(
        root=str(ROOT), prio=args.rt_priority, nice=args.nice, cpus=args.rt_affinity, stall=STALL_S
    )
    return subprocess.Popen([sys.executable, "-c", code], stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True)


def stop_control_during(proc: subprocess.Popen) -> dict | None:
    try:
        out, _err = proc.communicate(input="", timeout=30)
        return json.loads(out)
    except (subprocess.TimeoutExpired, json.JSONDecodeError):
        proc.kill()
        return None


def overlapping(step: dict, stalls: list, margin_s: float = 0.01) -> bool:
    """Whether a slow step (its perf_counter start and work) overlaps a control stall (+- margin)."""
    a, b = step.get("start_s", float("nan")) - margin_s, step.get("start_s", float("nan")) + step["work_s"] + margin_s
    return any(t < b and t + w > a for t, w in stalls)


def control_workload(args: argparse.Namespace) -> dict | None:
    """The machine's own jitter: a fixed piece of work every 10 ms, in a process with the
    run's settings, beside the same hog: what no code change in the loop can go below."""
    code = CONTROL.format(root=str(ROOT), prio=args.rt_priority, nice=args.nice, cpus=args.rt_affinity)
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    try:
        return json.loads(proc.stdout)
    except json.JSONDecodeError:
        return None


def ms(x: float | None) -> str:
    return "nan" if x is None else f"{1e3 * x:.3f}"


def at_s(x: float | None) -> str:
    """`` (reading at 12.3 s)``: when the reading of a largest latency arrived, s into the run."""
    return "" if x is None else f" (reading at {x:.1f} s)"


def keep_run(tmp: Path, dest: Path, proc: subprocess.CompletedProcess) -> None:
    """Copy the run's files from ``tmp`` to ``dest`` (created), with its stdout/stderr."""
    dest.mkdir(parents=True, exist_ok=True)
    for name in ("run.mcap", "hal.yaml", "field_loop_hold.yaml"):
        if (tmp / name).exists():
            shutil.copy2(tmp / name, dest / name)
    (dest / "stdout.json").write_text(proc.stdout)
    (dest / "stderr.txt").write_text(proc.stderr)
    print(f"kept the run in {dest}", file=sys.stderr)


def field_target(duration_s: float, hog: str, p99_s: float, missed: int) -> str:
    """Issue 18's field-loop target as this run shows it: p99 step work <= 2 ms and
    no tick reached late, over at least 5 minutes with a hog beside the run."""
    within = p99_s <= 0.002 and missed == 0
    caveats = [c for c, bad in (("under 5 min", duration_s < 299.0), ("no hog beside it", hog == "none")) if bad]
    shown = f"p99 step work {1e3 * p99_s:.2f} ms (<= 2), {missed} late ticks (0)"
    if caveats:
        return (
            f"{'within' if within else 'OUTSIDE'} the target's figures ({shown}), not under its conditions "
            f"({', '.join(caveats)})"
        )
    return f"{'met' if within else 'MISSED'}: {shown}"


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--duration", type=float, default=180.0, help="s of real-time loop (default 180)")
    ap.add_argument("--hog", choices=("none", "busy", "campaign"), default="none")
    ap.add_argument(
        "--hog-procs", type=int, default=os.cpu_count() or 2, help="hog processes/workers (default: one per CPU)"
    )
    ap.add_argument("--rt-priority", type=int, default=None)
    ap.add_argument("--nice", type=int, default=None)
    ap.add_argument("--rt-affinity", default=None)
    ap.add_argument("--gil-interval", type=float, default=None, help="ms")
    ap.add_argument("--lock-memory", action="store_true", help="maris run --lock-memory (mlockall)")
    ap.add_argument("--gc", choices=("auto", "freeze", "manual"), default="auto")
    ap.add_argument("--log-hz", type=float, default=20.0)
    ap.add_argument(
        "--no-health-prefetch",
        action="store_true",
        help="maris run --no-health-prefetch: the tree step polls the devices' health itself",
    )
    ap.add_argument(
        "--peer-priority",
        type=int,
        default=None,
        help="SCHED_FIFO priority of the peers' threads (0: normal priority; default: 40, below the "
        "run, when the run has --rt-priority, else 0, so they do not preempt an ordinary run)",
    )
    ap.add_argument(
        "--keep",
        default=None,
        metavar="DIR",
        help="copy the run's log, HAL config, mission and output to DIR (to read with `maris log`)",
    )
    ap.add_argument(
        "--actions",
        default=None,
        metavar="FILE",
        help="the mission's KCL actions file (default: the rig's, kcl/data/actions.yaml); e.g. another "
        "tree's, to compare two trees on the same task hierarchy",
    )
    ap.add_argument("--profile", default=None, metavar="PATH", help=argparse.SUPPRESS)  # cProfile of maris run -> PATH
    args = ap.parse_args()

    with tempfile.TemporaryDirectory() as tmpdir:
        tmp = Path(tmpdir)
        rig = FieldRig.start(max_runtime=args.duration + 180.0)
        peers = rig.peers
        hog = None
        try:
            peer_prio = args.peer_priority if args.peer_priority is not None else (40 if args.rt_priority else 0)
            peer_note = shield_peers(peers, peer_prio)
            cfg = rig.write_config(tmp / "hal.yaml")
            mission = tmp / "field_loop_hold.yaml"
            text = MISSION.format(duration=args.duration, max_duration=args.duration + 60.0)
            if args.actions:
                text += f"actions_file: {json.dumps(str(Path(args.actions).resolve()))}\n"
            mission.write_text(text)
            prefix = (
                [sys.executable, "-m", "cProfile", "-o", args.profile, "-m", "mission.cli"]
                if args.profile
                else [str(ROOT / ".venv" / "bin" / "maris")]
            )
            cmd = [
                *prefix,
                "run",
                str(mission),
                "--hal",
                str(cfg),
                "--json",
                "--log",
                str(tmp / "run.mcap"),
                "--log-hz",
                f"{args.log_hz:g}",
                "--gc",
                args.gc,
            ]
            for opt, val in (
                ("--rt-priority", args.rt_priority),
                ("--nice", args.nice),
                ("--rt-affinity", args.rt_affinity),
                ("--gil-interval", args.gil_interval),
            ):
                if val is not None:
                    cmd += [opt, str(val)]
            if args.lock_memory:
                cmd.append("--lock-memory")
            if args.no_health_prefetch:
                cmd.append("--no-health-prefetch")
            hog = start_hog(args.hog, args.hog_procs, tmp)
            if hog is not None:
                time.sleep(3.0)  # the hog at full load before the run starts
            control = control_workload(args)
            load0 = os.getloadavg()[0]
            during = start_control_during(args)
            try:
                usage0 = resource.getrusage(resource.RUSAGE_CHILDREN)
                proc = subprocess.run(cmd, cwd=ROOT, capture_output=True, text=True)
                usage1 = resource.getrusage(resource.RUSAGE_CHILDREN)  # before the control beside ends
            finally:
                beside = stop_control_during(during)
            cpu_user, cpu_sys = usage1.ru_utime - usage0.ru_utime, usage1.ru_stime - usage0.ru_stime
            load1 = os.getloadavg()[0]
            log_mb = (tmp / "run.mcap").stat().st_size / 1e6 if (tmp / "run.mcap").exists() else 0.0
            if args.keep:
                keep_run(tmp, Path(args.keep), proc)
        finally:
            stop_hog(hog)
            rig.stop()
    try:
        doc = json.loads(proc.stdout)
    except json.JSONDecodeError:
        print(
            f"maris run did not produce a result (exit {proc.returncode}):\n{proc.stdout[-2000:]}\n{proc.stderr[-4000:]}",
            file=sys.stderr,
        )
        return 1
    m = doc["metrics"]
    work, ticks = m["wall_step_work"], m.get("wall_ticks", {})
    lat, gcs = m.get("wall_latency", {}), m.get("wall_gc", {})
    proc_settings = m.get("wall_process") or {"policy": "other (default)", "nice": 0, "cpus": "all"}
    ahrs, joints = lat.get("ahrs", {}), lat.get("joints", {})
    settings = (
        f"gc={args.gc},rt_priority={args.rt_priority or 'none'},nice={args.nice if args.nice is not None else 'none'},"
        f"affinity={args.rt_affinity or 'all'},gil_interval_ms={args.gil_interval or 'default'},"
        f"lock_memory={int(args.lock_memory)},health_prefetch={int(not args.no_health_prefetch)}"
    )
    print(
        f"maris run of a hold-station mission, {args.duration:g} s requested, real time, base step 10 ms; "
        f"peers: 10 CiA 402 drives (host-only CAN), MAVLink vehicle, DVL 10 Hz, AHRS 50 Hz; log on "
        f"({args.log_hz:g} Hz devices, {log_mb:.1f} MB); actions: {args.actions or 'the rig default'}"
    )
    print(
        f"outcome {doc['outcome']} ({doc.get('failure_cause') or 'ok'}), {doc['duration_s']:.1f} s, {work['steps']} steps"
    )
    print(
        f"machine: {os.cpu_count()} CPUs, load average {load0:.1f} at start / {load1:.1f} at end; hog: {args.hog}"
        f"{'' if args.hog == 'none' else f' ({args.hog_procs} processes)'}"
    )
    print(f"process: {proc_settings}, gc {args.gc}; {peer_note}")
    print(
        f"process CPU     {cpu_user:.1f} s user + {cpu_sys:.1f} s system over the run's {doc['duration_s']:.1f} s "
        f"(all its threads, start-up included: {100 * (cpu_user + cpu_sys) / max(doc['duration_s'], 1e-9):.0f} % of one CPU)"
    )
    if control:
        print(
            f"control         a fixed ~0.5 ms pure-Python work every 10 ms, same settings and hog, just before: "
            f"p50 {ms(control['p50_s'])} ms  p99 {ms(control['p99_s'])} ms  max {ms(control['max_s'])} ms"
        )
    print(
        f"step work       p50 {ms(work['p50_s'])} ms  p99 {ms(work['p99_s'])} ms  p99.9 {ms(work['p999_s'])} ms  "
        f"max {ms(work['max_s'])} ms  (steps over 10 ms: {work['over_period']})"
    )
    print(
        f"deadlines       {ticks.get('missed', 0)} of {ticks.get('ticks', 0)} ticks reached late "
        f"(worst {ms(ticks.get('late_max_s'))} ms after its tick), {ticks.get('overruns', 0)} more than a period behind"
    )
    print(
        f"wake-up late    p50 {ms(ticks.get('late_p50_s'))} ms  p99 {ms(ticks.get('late_p99_s'))} ms  "
        f"max {ms(ticks.get('late_max_s'))} ms"
    )
    for name, d in (("AHRS", ahrs), ("joints", joints)):
        print(
            f"latency {name:<7} reading arrival -> first command handed to the drivers: p50 {ms(d.get('p50_s'))} ms  "
            f"p99 {ms(d.get('p99_s'))} ms  max {ms(d.get('max_s'))} ms{at_s(d.get('max_at_s'))}  ({d.get('n', 0)} readings)"
        )
    phases = m.get("phase_wall_s", {})
    print(
        "work by phase   "
        + ", ".join(
            f"{k} {1e6 * v / max(1, m['steps']):.0f}"
            for k, v in sorted(phases.items(), key=lambda kv: -kv[1])
            if k != "backend"
        )
        + " us/step (mean)"
    )
    print(
        f"gc              {gcs.get('collections', 0)} collections in the loop, longest {ms(gcs.get('max_s'))} ms, "
        f"total {ms(gcs.get('total_s'))} ms"
    )
    served = m.get("wall_health_prefetch")
    print(
        "health polls    "
        + (
            "on the loop thread at the tree step (--no-health-prefetch)"
            if served is None
            else f"{served.get('prefetched', 0)} computed between the steps by the drivers' prefetch "
            f"worker, {served.get('on_loop', 0)} on the loop thread (the worker not done, or a "
            f"second call in a step); {served.get('left_to_step', 0)} prefetches cut short near "
            "the tick"
        )
    )
    fl = m.get("wall_log_flush") or {}
    print(
        f"log flushes     {fl.get('n', 0)} at the end of their steps, after the work (not in the step work above): "
        f"p50 {ms(fl.get('p50_s'))} ms, max {ms(fl.get('max_s'))} ms"
    )
    imports = m.get("loop_imports") or []
    print(
        f"imports         {len(imports)} modules first imported inside the loop (each stalls its step)"
        + (f": {', '.join(imports)}" if imports else "")
    )
    slowest = m.get("wall_slowest_steps") or []
    stalls = beside["stalls"] if beside else []
    if beside:
        print(
            f"control beside  the same work every 10 ms for the whole run, another process: p50 {ms(beside['p50_s'])} ms  "
            f"p99 {ms(beside['p99_s'])} ms  max {ms(beside['max_s'])} ms; {len(stalls)} of {beside['n']} iterations "
            f"over {1e3 * STALL_S:g} ms (the machine stalled)"
        )
    if slowest:
        from mission.runtime.report import describe_step

        over = [e for e in slowest if e["work_s"] > 0.01]
        shared = sum(overlapping(e, stalls) for e in over)
        print(
            f"slowest steps   the {min(5, len(slowest))} longest of the run (phases in ms; CPU: the loop thread's own "
            "time, the rest of the step it waited; [machine]: the control beside stalled then too)"
        )
        for entry in slowest[:5]:
            print("                " + describe_step(entry) + (" [machine]" if overlapping(entry, stalls) else ""))
        if over:
            print(
                f"                of the {len(over)} kept steps over 10 ms, {shared} overlapped a stall of the control "
                "beside"
            )
    late_events = ticks.get("late_events") or []
    if late_events and beside:
        # a late tick arrived at `at`, `late` s after its time: its period and lateness span [at - late - 0.01, at]
        near = sum(any(t < at and t + w > at - late - 0.01 for t, w in stalls) for at, late in late_events)
        print(
            f"late ticks      {near} of {len(late_events)} overlapped a stall of the control beside (the machine "
            "stalled then too)"
        )
    print("target          " + field_target(doc["duration_s"], args.hog, work["p99_s"], ticks.get("missed", 0)))
    print(
        f"field_loop duration_s={doc['duration_s']:.1f} hog={args.hog} work_p50_ms={ms(work['p50_s'])} "
        f"work_p99_ms={ms(work['p99_s'])} work_max_ms={ms(work['max_s'])} missed={ticks.get('missed', 0)} "
        f"worst_late_ms={ms(ticks.get('late_max_s'))} overruns={ticks.get('overruns', 0)} "
        f"latency_ahrs_p50_ms={ms(ahrs.get('p50_s'))} latency_ahrs_p99_ms={ms(ahrs.get('p99_s'))} "
        f"latency_joints_p99_ms={ms(joints.get('p99_s'))} loop_imports={len(imports)} "
        f"cpu_s={cpu_user + cpu_sys:.1f} settings={settings}"
    )
    return 0 if doc["outcome"] == "succeeded" else 1


if __name__ == "__main__":
    sys.exit(main())
