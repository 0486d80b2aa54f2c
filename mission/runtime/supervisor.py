"""The supervisor: one multi-rate loop driving a behaviour tree, the KCL and the
devices of a :class:`hal.interfaces.Backend`, under the safety monitors.

Each base step (the arm KCL period, ``1/arm_hz`` s, on the backend clock):

1. operator commands (keys, signals, script) at the tree rate;
2. device reads (health and the slow streams at the tree rate); safety
   monitors (watchdogs, envelope, drive faults, NaN);
3. tree tick (tree rate) while running, abort-path tick while aborting;
4. vehicle KCL step (vehicle rate) and arm KCL step (every base step) while
   the tree or abort path is active; zero commands while paused or stopped;
5. logging at the configured rates; the log's periodic flush, when due, after
   the step's work (:mod:`mission.runtime.logflush`);
6. ``backend.advance(dt)`` - lockstep simulation, or waiting in real time.

A software error raised by a leaf of the mission tree interrupts the tree and
runs the mission's abort path. A breach ends the run the way the fault table says (``docs/faults.md``,
:data:`mission.runtime.safety.FAULT_TABLE`): ``abort`` interrupts the tree,
stops the KCL and runs the mission's abort path (or, without one, a built-in
safe stop); ``abort_short`` runs the abort path for at most ``short_abort_s``;
``stop`` (unsafe to move: non-finite values, an arm drive fault, the vehicle
link) skips the abort path, or cuts a running one short, for the safe stop; so
does a second interrupt. ``leaf`` and ``warn`` breaches are logged once and
leave the tree running (the leaf using the device fails by itself). An operator
stop before engagement ends the run without arming or enabling anything. A
failing tree also runs the abort path and ends ``failed``. Runs that stop on a
fault, an abort or a software error end with zero velocity commands,
``safe_stop()`` on every device and a settle period (``settle_s``) so the
vehicle is still when the result is reported; every run ends disarmed, and the
last logged commands are the final zero ones. Python logging records (drivers,
canopen, ...) become ``python_log`` events (:mod:`mission.runtime.pylog`).

Timing: ``phase_wall_s`` accumulates the wall time per loop phase (for
``benchmarks/dry_run.py``); in real time, steps slower than the base period
are counted (``wall_overrun_steps`` in the result metrics).
"""

from __future__ import annotations

import sys
import time
import traceback
from collections.abc import Callable
from typing import Any

import numpy as np

from hal.interfaces import Backend
from mission.runtime.actuation import Actuation
from mission.runtime.context import Event, EventSink, RuntimeContext
from mission.runtime.endings import EndingsMixin
from mission.runtime.inputs import AltitudeFloorWatch, DevicePoller
from mission.runtime.lifecycle import Lifecycle
from mission.runtime.logflush import LoopFlush
from mission.runtime.operator import CommandQueue
from mission.runtime.preflight import operator_stop as operator_stop_now
from mission.runtime.preflight import preflight
from mission.runtime.pylog import LogCapture
from mission.runtime.recorder import RunRecorder
from mission.runtime.result import RunResult, SupervisorOptions, build_result
from mission.runtime.rtprocess import GcControl, put_loop_first
from mission.runtime.safety import Breach, JointLimits, SafetyMonitor, all_finite
from mission.runtime.schedule import make_schedule
from mission.runtime.steptiming import StepTimes
from mission.runtime.ticking import TreeTickMixin
from mission.runtime.truth import TruthTracker
from mission.runtime.viz import VizRecorder

__all__ = ["RunResult", "Supervisor", "SupervisorOptions", "UNSAFE_TO_MOVE"]

#: Breach kinds after which no controller output may reach the devices (see safety.FAULT_TABLE).
UNSAFE_TO_MOVE = ("non_finite", "drive_fault", "vehicle_link")


#: Where in their period the log jobs run (fraction of it), so that not every slow job lands
#: on the tree tick's step: the 3D view (/tf, 10 Hz) at step 2 of each 10. The KCL telemetry
#: and the device log stay with the tree tick and the vehicle KCL: `maris log summary` dates
#: action switches from the former, `maris calibrate` pairs logged commands and readings
#: of the latter with the vehicle steps. (The devices' health poll stays on the tree step
#: too: moved half a period off it in a field run, late wake-ups of the pacer became
#: frequent, 67 late ticks in 120 s against none; see docs/performance-history.md. Real drivers
#: compute it between the steps instead, for the tree step: ``Backend.prefetch_health``.)
LOG_OFFSETS = {"tf_log": 0.2}

TreeFactory = Callable[[RuntimeContext], Any]


class Supervisor(TreeTickMixin, EndingsMixin):
    """Runs one mission once. Build, then call :meth:`run` (or :meth:`request` from
    another thread/handler to pause, resume, abort)."""

    def __init__(
        self,
        backend: Backend,
        controller: Any,
        *,
        rates: Any,
        safety: Any,
        make_tree: TreeFactory,
        make_abort_tree: TreeFactory | None = None,
        measure: Callable[[Any, Any, float], Any],
        blackboard: Any = None,
        log: Any = None,
        model: Any = None,
        mission: Any = None,
        options: SupervisorOptions | None = None,
        commands: CommandQueue | None = None,
        pollers: list[Callable[[float], None]] | None = None,
        on_progress: Callable[[float, str, str | None, str | None], None] | None = None,
        on_event: Callable[[Event], None] | None = None,
        log_capture: Callable[[Callable[..., Any]], Any] = LogCapture,
    ) -> None:
        """``log_capture(emit)``: the capture of Python logging records (drivers' warnings)
        into events, :class:`mission.runtime.pylog.LogCapture`; the input record of a
        run wraps it, a replay serves the logged records (:mod:`mission.replay`)."""
        self.backend = backend
        self._log_capture = log_capture
        self.clock = backend.clock
        self.devices = backend.devices
        self.controller = controller
        self.options = options or SupervisorOptions()
        self.monitor = SafetyMonitor(safety, self.options.velocity_watchdog_s)
        self.log = log
        self.rec = RunRecorder(log)
        self.model = model
        self.safety = safety
        self.commands = commands or CommandQueue()
        self.pollers = pollers or []
        self.on_progress = on_progress
        self.make_tree = make_tree
        self.make_abort_tree = make_abort_tree
        self.measure = measure
        self.events = EventSink(self.clock)
        self.events.listeners.append(self._log_event)
        if on_event is not None:
            self.events.listeners.append(on_event)
        self.ctx = RuntimeContext(
            self.clock, self.devices, controller, blackboard, self.events, mission=mission, model=model
        )
        self.lifecycle = Lifecycle(self._state_changed)
        o = self.options
        self.schedule = make_schedule(
            rates.arm_hz,
            {
                "tree": rates.tree_hz,
                "vehicle": rates.vehicle_hz,
                "kcl_log": o.kcl_log_hz,
                "device_log": o.device_log_hz,
                "truth_log": o.ground_truth_log_hz,
                "tf_log": o.tf_log_hz,
            },
            LOG_OFFSETS,
        )
        self.dt = self.schedule.dt
        self.tree: Any = None
        self.abort_tree: Any = None
        self.t0 = 0.0
        self.step = 0
        self.act = Actuation(self.devices, controller, self.clock, self.events)
        self.poller = DevicePoller(self.clock, self.devices, self.monitor, self.rec)
        self.truth = TruthTracker(backend, self.events, self.rec)
        self.viz = VizRecorder(
            log, model, mission=mission, backend=backend, joint_names=getattr(self.devices.arm, "joint_names", ())
        )
        self.failure_cause: str | None = None
        self.altitude_watch = AltitudeFloorWatch(getattr(safety, "min_altitude_m", 0.0), self.events)
        self._fail_after_abort = False
        self._abort_started = 0.0
        self._abort_deadline = float("inf")
        self._pylog: LogCapture | None = None
        self._active_breaches: set[tuple[str, str]] = set()
        self._paused_action: str | None = None
        self._actions: list[tuple[float, str]] = []
        self._abort_root: Any = None
        self.leaf: str | None = None
        self.wall_s = 0.0
        #: Steps whose computation took longer than the base period, and the longest (s).
        self.overrun_steps = 0
        self.max_step_compute_s = 0.0
        #: Wall time (s) spent per phase of the loop, for benchmarks/dry_run.py.
        self.phase_wall_s = dict.fromkeys(
            ("devices", "safety", "tree", "kcl_vehicle", "kcl_arm", "log_progress", "backend"), 0.0
        )
        #: Wall time (s) of each step's work (everything but the log's flush and ``backend.advance``).
        self.step_times = StepTimes()
        self.log_flush = LoopFlush(log)
        #: Garbage-collector policy of the loop (``SupervisorOptions.gc_mode``).
        self.gc = GcControl(self.options.gc_mode)
        self.loop_tick0 = 0
        #: Modules first imported while the loop ran (each one stalled a step: reading and
        #: executing a module takes ms, tens of ms on a loaded machine); [] is the aim.
        self.loop_imports: list[str] = []

    # ------------------------------------------------------------------ API
    def request(self, command: str, source: str = "api") -> None:
        """Ask for ``pause``, ``resume``, ``toggle``, ``abort`` or ``stop_now``."""
        self.commands.put(command, source)

    def run(self) -> RunResult:
        """Open the backend's devices, preflight, run to an end state, stop everything.

        Field faults end the run as ``aborted``/``failed`` with a cause. A software
        error (an exception from a leaf, the KCL, a driver) also stops all motion
        and ends the run ``failed`` with cause ``internal error: ...`` and the
        traceback in an ``internal_error`` event; it is re-raised only with
        ``SupervisorOptions.raise_internal_errors``."""
        wall0 = time.perf_counter()
        self.t0 = self.poller.t0 = self.clock.now()
        with self._log_capture(self.events.emit) as self._pylog:
            return self._run(wall0)

    def pylog_drain(self) -> None:
        """Turn queued Python logging records into events (loop thread only)."""
        if self._pylog is not None:
            self._pylog.drain()

    def _run(self, wall0: float) -> RunResult:
        try:
            self.lifecycle.go("start")
            stop = None
            try:
                self.backend.open()
            except Exception as exc:  # noqa: BLE001 - e.g. a CAN interface or serial port missing
                problems = [f"cannot open the devices: {type(exc).__name__}: {exc}"]
            else:
                outcome = preflight(self)
                problems, stop = outcome.problems, outcome.stop
            if stop is None and not problems:
                self.tree = self.make_tree(self.ctx)
                self.tree.setup_with_descendants()
                if self.make_abort_tree is not None:  # built now: a broken abort path shows before motion
                    self._abort_root = self.make_abort_tree(self.ctx)
                    self._abort_root.setup_with_descendants()
                stop = operator_stop_now(self.commands)  # one that came while the trees were built
                if stop is None:
                    problems = self.act.engage()  # confirmed arming, or why not
            if stop is not None:  # asked to stop before anything was armed or enabled
                self.failure_cause = f"operator stop before engagement ({stop[1]})"
                self.events.emit(
                    "operator",
                    f"{stop[0]} ({stop[1]}) before engagement: nothing armed or enabled",
                    level="warning",
                    command=stop[0],
                    source=stop[1],
                )
                self.lifecycle.go("abort", self.failure_cause)
                self.lifecycle.go("abort_done", self.failure_cause)
            elif problems:
                self.failure_cause = "preflight: " + "; ".join(problems)
                self.events.emit("preflight", self.failure_cause, level="fault")
                self.lifecycle.go("preflight_failed", self.failure_cause)
            else:
                self.altitude_watch.start(self.devices.vehicle.navigation())
                if self.viz.active:
                    self.viz.start(self.clock.now(), self.devices.vehicle.navigation(), self.devices.arm.joint_state())
                self.lifecycle.go("preflight_ok")
                self._loop()
                self.altitude_watch.end()
            self.act.disengage()
            self._log_final_commands()
        except Exception as exc:  # noqa: BLE001 - a software fault must still stop the vehicle
            self.failure_cause = f"internal error: {type(exc).__name__}: {exc}"
            self.events.emit("internal_error", self.failure_cause, level="fault", traceback=traceback.format_exc())
            self.act.safe_stop_all()
            try:
                self._settle()  # zero commands while the vehicle comes to rest, logged
            except Exception as settle_exc:  # noqa: BLE001 - keep going to the disarm
                self.events.emit("safe_stop", f"settle after the error failed: {settle_exc}", level="fault")
            self.act.disengage()
            if not self.lifecycle.finished:
                if self.lifecycle.state == "aborting":
                    self.lifecycle.go("end_failed", self.failure_cause)
                elif self.lifecycle.can("fail"):
                    self.lifecycle.go("fail", self.failure_cause)
                elif self.lifecycle.can("preflight_failed"):
                    self.lifecycle.go("preflight_failed", self.failure_cause)
            self.wall_s = time.perf_counter() - wall0
            result = self._result()
            self._write_result(result)
            if self.options.raise_internal_errors:
                raise
            return result
        self.wall_s = time.perf_counter() - wall0
        result = self._result()
        self._write_result(result)
        return result

    # ------------------------------------------------------------ preflight
    def _log_final_commands(self) -> None:
        """Log the devices once more after the final zero commands, so the log ends on them."""
        if self.rec.active:
            try:
                self.rec.devices(
                    self.clock.now(),
                    self.devices,
                    self.devices.vehicle.navigation(),
                    self.devices.arm.joint_state(),
                    self.act.vehicle_cmd,
                    self.act.arm_cmd,
                )
            except Exception as exc:  # noqa: BLE001 - logging must not mask the result
                self.events.emit("log", f"final command sample not logged: {exc}", level="warning")
        self.pylog_drain()

    # ----------------------------------------------------------------- loop
    def _loop(self) -> None:
        prof = self.phase_wall_s
        acc = [0.0] * 7  # devices, safety, tree, kcl_vehicle, kcl_arm, log_progress, backend
        #: Backend tick index of the loop's second step: the loop's own deadline figures
        #: (the first is measured against the preflight's last tick, before the engagement).
        self.loop_tick0 = int(getattr(self.backend, "ticks", 0)) + 1
        process = self.options.process
        if process is not None and process.get("policy") == "fifo":  # maris run --rt-priority
            process["loop_first"] = put_loop_first()  # the drivers' threads one priority below the loop
        modules = set(sys.modules)
        self.gc.start()
        self.log_flush.start()
        try:
            self._steps(acc)
        finally:
            self.log_flush.stop()
            self.gc.stop()
            # a module first imported inside the loop stalled its step (ms to tens of ms)
            self.loop_imports = sorted(set(sys.modules) - modules)
            for name, sec in zip(prof, acc):
                prof[name] += sec

    def _steps(self, acc: list[float]) -> None:
        """The loop itself (see the module docstring); ``acc`` accumulates the wall
        time per phase, in the order of :attr:`phase_wall_s`."""
        jobs = self.schedule.jobs
        tree_div, tree_ph = jobs["tree"].divider, jobs["tree"].phase
        veh_div, veh_ph = jobs["vehicle"].divider, jobs["vehicle"].phase
        truth_div, truth_ph = jobs["truth_log"].divider, jobs["truth_log"].phase
        kcl_div, kcl_ph = jobs["kcl_log"].divider, jobs["kcl_log"].phase
        dev_div, dev_ph = jobs["device_log"].divider, jobs["device_log"].phase
        tf_div, tf_ph = jobs["tf_log"].divider, jobs["tf_log"].phase
        max_t = self.options.max_time_s
        lifecycle = self.lifecycle
        devices = self.devices
        navigation, joint_state = devices.vehicle.navigation, devices.arm.joint_state
        now_fn = self.clock.now
        model = self.model
        monitor = self.monitor
        controller = self.controller
        act = self.act
        rec = self.rec
        dt = self.dt
        times = self.step_times
        work = times.work
        # real devices only (a paced simulation stamps readings in simulated time); their clock
        # read directly: a recorded read would be one more input for `maris log replay` to serve
        wall_clock = getattr(self.backend, "wall_clock", None)
        latency, wall_now = (times.command_sent, wall_clock.now) if wall_clock is not None else (None, None)
        if wall_now is not None:
            times.count_from_t = wall_now()  # readings of the preflight and the engagement waited for it
        gc_tick = self.gc.tick if self.gc.manual else None
        clock = time.perf_counter
        # in real time, the loop thread's CPU time of the slowest steps (did they compute, or wait?)
        thread_cpu = time.thread_time if wall_clock is not None else None
        cpu0 = cpu7 = 0.0
        slow_floor = 0.0  # the work (s) a step must exceed to be among the slowest kept
        poller = self.poller
        quick = monitor.quick_margins
        no_breaches: list[Breach] = []
        limits = JointLimits(model.joint_lower, model.joint_upper) if model is not None else None
        # real drivers compute the tree step's health polls between the steps (hal.drivers.health_prefetch)
        prefetch_health = getattr(self.backend, "prefetch_health", None)
        flush_log, flushes = (
            self.log_flush.flush_if_due,
            self.log_flush.times,
        )  # after the work (mission.runtime.logflush)
        while not lifecycle.finished:
            c0 = clock()
            if thread_cpu is not None:
                cpu0 = thread_cpu()
            now = now_fn()
            step = self.step
            tree_due = step % tree_div == tree_ph
            if tree_due:
                self.pylog_drain()
                for poll in self.pollers:
                    poll(now)
                for cmd, source in self.commands.drain():
                    self._operator(cmd, source)
                if lifecycle.finished:
                    break
            nav = navigation()
            js = joint_state()
            if nav.altitude is None:
                self.altitude_watch.unknown_for(dt)
            c1 = clock()
            check_t = poller.read(tree_due)
            margins = quick(check_t, check_t - poller.t0, nav, js, poller.polled)
            if margins is None:  # a breach, or maybe one: the full check decides
                breaches, margins = monitor.check(poller.snapshot_at(check_t, nav, js))
            else:
                breaches = no_breaches
            if limits is not None:  # finite=True on the fast path: it checked every joint position
                jm = limits.margin(js.position, finite=breaches is no_breaches)
                margins["joint_limits_rad"] = jm
                monitor.record("joint_limits_rad", jm, now - self.t0)
            if breaches or self._active_breaches:
                self._handle_breaches(breaches)
            state = lifecycle.state
            if max_t is not None and now - self.t0 > max_t and state in ("running", "paused"):
                self._begin_abort(f"run time cap of {max_t:g} s reached", failed=True)
                state = lifecycle.state
            c2 = clock()
            if tree_due:
                if state == "running":
                    self._tick_tree()
                elif state == "aborting":
                    self._tick_abort()
            c3 = clock()
            if lifecycle.finished:
                break
            state = lifecycle.state
            if state == "running" or (state == "aborting" and self.abort_tree is not None):
                meas = self.measure(nav, js, now)
                # the vehicle reference is held between vehicle steps (zeroed by any stop)
                if step % veh_div == veh_ph:
                    vehicle_cmd = np.asarray(controller.vehicle_step(meas, now), dtype=float)
                    c4 = clock()
                    arm_cmd = np.asarray(controller.arm_step(meas, now), dtype=float)
                    c5 = clock()
                    ok = all_finite(vehicle_cmd) and all_finite(arm_cmd)
                else:  # the held reference was sent, so finite (or zeroed): only the arm's is new
                    vehicle_cmd = act.vehicle_cmd
                    c4 = clock()
                    arm_cmd = np.asarray(controller.arm_step(meas, now), dtype=float)
                    c5 = clock()
                    ok = all_finite(arm_cmd)
                if not ok:
                    self._handle_breaches(
                        [
                            Breach(
                                "non_finite",
                                "controller",
                                f"non-finite KCL output: vehicle {vehicle_cmd}, arm {arm_cmd}",
                            )
                        ],
                        complete=False,
                    )
                    act.zero()
                else:
                    act.send(vehicle_cmd, arm_cmd)
                    if latency is not None:
                        latency(wall_now(), nav.t, js.t)
            else:
                c4 = c5 = clock()
                act.zero()
            c6 = clock()
            if step % truth_div == truth_ph:
                self.truth.sample(now)
            if rec.log is not None:
                if step % kcl_div == kcl_ph:
                    rec.kcl(now, controller.telemetry(), margins)
                if step % dev_div == dev_ph:
                    rec.devices(now, devices, nav, js, act.vehicle_cmd, act.arm_cmd)
                if step % tf_div == tf_ph:
                    self._log_frames(now, nav, js)
            if tree_due:
                if self.on_progress is not None:
                    self.on_progress(now - self.t0, state, self._current_action(), self.leaf)
                if gc_tick is not None:
                    gc_tick()  # --gc manual: the young generation, inside the step's measured work
            if prefetch_health is not None and (step + 1) % tree_div == tree_ph:
                prefetch_health()
            c7 = clock()
            if thread_cpu is not None:
                cpu7 = thread_cpu()
            c7f = c7
            if flush_log is not None and flush_log():
                c7f = clock()
                flushes.append(c7f - c7)
            self.backend.advance(dt)
            c8 = clock()
            self.step = step + 1
            acc[0] += (c1 - c0) + (c6 - c5)
            acc[1] += c2 - c1
            acc[2] += c3 - c2
            acc[3] += c4 - c3
            acc[4] += c5 - c4
            acc[5] += c7f - c6
            acc[6] += c8 - c7f
            compute = c7 - c0
            work.append(compute)
            if compute > self.max_step_compute_s:
                self.max_step_compute_s = compute
            if compute > dt:
                self.overrun_steps += 1  # in real time, this step could not keep the base rate
            if compute > slow_floor:
                slow_floor = times.note_slow(
                    compute,
                    step,
                    now - self.t0,
                    tree_due,
                    (c1 - c0, c2 - c1, c3 - c2, c4 - c3, c5 - c4, c6 - c5, c7 - c6),
                    cpu7 - cpu0 if thread_cpu is not None else None,
                    c0,
                )

    # -------------------------------------------------------------- logging
    def _log_event(self, ev: Event) -> None:
        self.rec.event(ev)
        self.viz.event(ev)

    def _log_frames(self, now: float, nav: Any, js: Any) -> None:
        """The 3D view: frame tree, named joints, goals (see :mod:`mission.runtime.viz`)."""
        detector = self.devices.detector
        self.viz.frames(
            now,
            nav,
            js,
            self.controller,
            self.ctx.blackboard,
            detector.latest() if detector is not None else None,
            self.truth.last,
        )

    def _state_changed(self, previous: str, state: str, trigger: str, reason: str) -> None:
        self.rec.state(self.clock.now(), previous, state, trigger, reason)
        if self.on_progress is not None:
            self.on_progress(self.clock.now() - self.t0, state, self._current_action(), self.leaf)

    # --------------------------------------------------------------- result
    def _result(self) -> RunResult:
        return build_result(self)

    def _write_result(self, result: RunResult) -> None:
        d = result.to_dict()
        d.pop("log_path", None)
        self.rec.result(self.clock.now(), d)
