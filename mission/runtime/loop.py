"""The supervisor's multi-rate loop, from the engagement to an end state.

Each base step (the arm KCL period, ``1/arm_hz`` s, on the backend clock):

1. operator requests (keys, signals, script) at the tree rate;
2. device reads (health and the slow streams at the tree rate); safety
   monitors (watchdogs, envelope, drive faults, NaN);
3. tree tick (tree rate) while running, abort-path tick while aborting;
4. vehicle KCL step (vehicle rate) and arm KCL step (every base step) while
   the tree or abort path is active; zero commands while paused or stopped;
5. logging at the configured rates; the log's periodic flush, when due, after
   the step's work (:mod:`mission.runtime.logflush`);
6. ``backend.advance(dt)``: lockstep simulation, or waiting in real time.

:class:`SupervisorLoop` also measures the loop's wall time: per phase
(``phase_wall_s``), per step (:class:`mission.runtime.steptiming.StepTimes`),
the steps slower than the base period, and the modules first imported while it
ran. Its per-step code keeps the collaborators it calls in local names: it runs
at the arm rate.
"""

from __future__ import annotations

import sys
import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

from hal.interfaces import Backend, JointState, NavigationState
from mission.runtime.actuation import Actuation
from mission.runtime.context import RuntimeContext
from mission.runtime.endings import Endings
from mission.runtime.inputs import AltitudeFloorWatch, DevicePoller
from mission.runtime.lifecycle import Lifecycle
from mission.runtime.logflush import LoopFlush
from mission.runtime.recorder import RunRecorder
from mission.runtime.requests import OperatorRequests
from mission.runtime.result import SupervisorOptions
from mission.runtime.rtprocess import GcControl, put_loop_first
from mission.runtime.safety import Breach, SafetyMonitor, all_finite
from mission.runtime.samples import LogSamples
from mission.runtime.steps import BaseSteps
from mission.runtime.steptiming import StepTimes
from mission.runtime.trees import TreeRunner

#: The KCL measurement from the step's readings: ``measure(nav, js, t)``.
Measure = Callable[[NavigationState, JointState, float], Any]
#: ``on_progress(elapsed_s, state, action, leaf)``: at each tree tick and state change.
ProgressCallback = Callable[[float, str, str | None, str | None], None]

#: The loop's phases, in the order of :attr:`SupervisorLoop.phase_wall_s`.
PHASES = ("devices", "safety", "tree", "kcl_vehicle", "kcl_arm", "log_progress", "backend")


@dataclass
class LoopParts:
    """The run's parts the loop drives, built by :class:`mission.runtime.supervisor.Supervisor`."""

    backend: Backend
    #: Clock, devices, controller and model of the run (the leaves' context).
    ctx: RuntimeContext
    lifecycle: Lifecycle
    steps: BaseSteps
    trees: TreeRunner
    endings: Endings
    requests: OperatorRequests
    monitor: SafetyMonitor
    poller: DevicePoller
    altitude_watch: AltitudeFloorWatch
    act: Actuation
    rec: RunRecorder
    samples: LogSamples
    measure: Measure
    options: SupervisorOptions
    #: Turns queued Python logging records into events (loop thread only).
    drain_pylog: Callable[[], None]
    on_progress: ProgressCallback | None = None


class SupervisorLoop:
    """The loop of one run (see the module docstring) and its wall-clock figures."""

    def __init__(self, parts: LoopParts) -> None:
        self.parts = parts
        #: Steps whose computation took longer than the base period, and the longest (s).
        self.overrun_steps = 0
        self.max_step_compute_s = 0.0
        #: Wall time (s) spent per phase of the loop, for benchmarks/dry_run.py.
        self.phase_wall_s = dict.fromkeys(PHASES, 0.0)
        #: Wall time (s) of each step's work (everything but the log's flush and ``backend.advance``).
        self.step_times = StepTimes()
        self.log_flush = LoopFlush(parts.rec.log)
        #: Garbage-collector policy of the loop (``SupervisorOptions.gc_mode``).
        self.gc = GcControl(parts.options.gc_mode)
        #: Backend tick index of the loop's second step: the loop's own deadline figures
        #: (the first is measured against the preflight's last tick, before the engagement).
        self.loop_tick0 = 0
        #: Modules first imported while the loop ran (each one stalled a step: reading and
        #: executing a module takes milliseconds); [] is the aim.
        self.loop_imports: list[str] = []

    def run(self, t0: float) -> None:
        """Step until the lifecycle ends; ``t0``: the run's start (backend clock, s)."""
        parts = self.parts
        prof = self.phase_wall_s
        acc = [0.0] * len(PHASES)
        self.loop_tick0 = int(getattr(parts.backend, "ticks", 0)) + 1
        process = parts.options.process
        if process is not None and process.get("policy") == "fifo":  # maris run --rt-priority
            process["loop_first"] = put_loop_first()  # the drivers' threads one priority below the loop
        modules = set(sys.modules)
        self.gc.start()
        self.log_flush.start()
        try:
            self._steps(acc, t0)
        finally:
            parts.rec.write_kcl()
            self.log_flush.stop()
            self.gc.stop()
            # a module first imported inside the loop stalled its step
            self.loop_imports = sorted(set(sys.modules) - modules)
            for name, sec in zip(prof, acc):
                prof[name] += sec

    def _steps(self, acc: list[float], t0: float) -> None:
        """The steps (see the module docstring); ``acc`` accumulates the wall time per
        phase, in the order of :data:`PHASES`."""
        parts = self.parts
        steps = parts.steps
        jobs = steps.schedule.jobs
        tree_div, tree_ph = jobs["tree"].divider, jobs["tree"].phase
        veh_div, veh_ph = jobs["vehicle"].divider, jobs["vehicle"].phase
        truth_div, truth_ph = jobs["truth_log"].divider, jobs["truth_log"].phase
        kcl_div, kcl_ph = jobs["kcl_log"].divider, jobs["kcl_log"].phase
        dev_div, dev_ph = jobs["device_log"].divider, jobs["device_log"].phase
        tf_div, tf_ph = jobs["tf_log"].divider, jobs["tf_log"].phase
        max_t = parts.options.max_time_s
        lifecycle = parts.lifecycle
        backend = parts.backend
        ctx = parts.ctx
        devices = ctx.devices
        navigation, joint_state = devices.vehicle.navigation, devices.arm.joint_state
        now_fn = ctx.clock.now
        monitor = parts.monitor
        controller = ctx.controller
        act = parts.act
        rec = parts.rec
        samples = parts.samples
        truth_sample = samples.truth.sample
        trees = parts.trees
        endings = parts.endings
        requests = parts.requests
        measure = parts.measure
        drain_pylog = parts.drain_pylog
        on_progress = parts.on_progress
        altitude_watch = parts.altitude_watch
        dt = steps.dt
        times = self.step_times
        work = times.work
        # real devices only (a paced simulation stamps readings in simulated time); their clock
        # read directly: a recorded read would be one more input for `maris log replay` to serve
        wall_clock = getattr(backend, "wall_clock", None)
        latency, wall_now = (times.command_sent, wall_clock.now) if wall_clock is not None else (None, None)
        if wall_now is not None:
            times.count_from_t = wall_now()  # readings of the preflight and the engagement waited for it
        gc_tick = self.gc.tick if self.gc.manual else None
        clock = time.perf_counter
        # in real time, the loop thread's CPU time of the slowest steps (did they compute, or wait?)
        thread_cpu = time.thread_time if wall_clock is not None else None
        cpu0 = cpu7 = 0.0
        slow_floor = 0.0  # the work (s) a step must exceed to be among the slowest kept
        poller = parts.poller
        check, joint_margin = monitor.check, monitor.joint_margin
        # real drivers compute the tree step's health polls between the steps (hal.drivers.health_prefetch)
        prefetch_health = getattr(backend, "prefetch_health", None)
        # after the work (mission.runtime.logflush)
        flush_log, flushes = self.log_flush.flush_if_due, self.log_flush.times
        while not lifecycle.finished:
            c0 = clock()
            if thread_cpu is not None:
                cpu0 = thread_cpu()
            now = now_fn()
            step = steps.index
            tree_due = step % tree_div == tree_ph
            if tree_due:
                drain_pylog()
                requests.poll(now)
                if lifecycle.finished:
                    break
            nav = navigation()
            js = joint_state()
            if nav.altitude is None:
                altitude_watch.unknown_for(dt)
            c1 = clock()
            check_t = poller.read(tree_due)
            breaches, margins = check(check_t, check_t - t0, nav, js, poller.polled)
            jm = joint_margin(js.position, now - t0)
            if jm is not None:
                margins["joint_limits_rad"] = jm
            if breaches or endings.active_breaches:
                endings.handle_breaches(breaches)
            state = lifecycle.state
            if max_t is not None and now - t0 > max_t and state in ("running", "paused"):
                endings.begin_abort(f"run time cap of {max_t:g} s reached", failed=True)
                state = lifecycle.state
            c2 = clock()
            if tree_due:
                if state == "running":
                    endings.tick_main()
                elif state == "aborting":
                    endings.tick_abort()
            c3 = clock()
            if lifecycle.finished:
                break
            state = lifecycle.state
            if state == "running" or (state == "aborting" and trees.abort_running is not None):
                meas = measure(nav, js, now)
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
                    endings.handle_breaches(
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
                    if latency is not None and wall_now is not None:
                        latency(wall_now(), nav.t, js.t)
            else:
                c4 = c5 = clock()
                act.zero()
            c6 = clock()
            if step % truth_div == truth_ph:
                truth_sample(now)
            if rec.log is not None:
                rec.write_kcl()  # the tree step's, built here: off the longest step
                if step % kcl_div == kcl_ph:
                    rec.kcl(now, controller.telemetry_snapshot(), margins)
                if step % dev_div == dev_ph:
                    rec.devices(now, devices, nav, js, act.vehicle_cmd, act.arm_cmd)
                if step % tf_div == tf_ph:
                    samples.frames(now, nav, js)
            if tree_due:
                if on_progress is not None:
                    on_progress(now - t0, state, trees.current_action(), trees.leaf)
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
            backend.advance(dt)
            c8 = clock()
            steps.index = step + 1
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
                    now - t0,
                    tree_due,
                    (c1 - c0, c2 - c1, c3 - c2, c4 - c3, c5 - c4, c6 - c5, c7 - c6),
                    cpu7 - cpu0 if thread_cpu is not None else None,
                    c0,
                )
