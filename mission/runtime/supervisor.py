"""The supervisor: one run of a behaviour tree, the KCL and the devices of a
:class:`hal.interfaces.Backend`, under the safety monitors.

:class:`Supervisor` builds the parts of a run and runs them in order: open the
devices, the preflight (:mod:`mission.runtime.preflight`), the trees
(:mod:`mission.runtime.trees`), the engagement, the multi-rate loop
(:mod:`mission.runtime.loop`), the disengagement, and the result. The parts:

* :class:`~mission.runtime.trees.TreeRunner`: the main tree and the abort path;
* :class:`~mission.runtime.endings.Endings`: breaches, the trees' ends and the
  operator's stops turned into the run's end (with
  :class:`~mission.runtime.endings.SafeStop`);
* :class:`~mission.runtime.requests.OperatorRequests`: pause, resume, abort;
* :class:`~mission.runtime.loop.SupervisorLoop`: the steps and their wall time;
* device reads and safety checks (:mod:`mission.runtime.inputs`,
  :mod:`mission.runtime.safety`), commands (:mod:`mission.runtime.actuation`),
  the log (:mod:`mission.runtime.recorder`, :mod:`mission.runtime.samples`).

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

Timing: the loop's ``phase_wall_s`` accumulates the wall time per loop phase (for
``benchmarks/dry_run.py``); in real time, steps slower than the base period
are counted (``wall_overrun_steps`` in the result metrics).
"""

from __future__ import annotations

import time
import traceback
from collections.abc import Callable
from typing import Any

import numpy as np

from hal.interfaces import Backend
from mission.runtime.actuation import Actuation
from mission.runtime.context import Event, EventSink, RuntimeContext
from mission.runtime.endings import Endings, SafeStop
from mission.runtime.inputs import AltitudeFloorWatch, DevicePoller
from mission.runtime.lifecycle import Lifecycle
from mission.runtime.loop import LoopParts, Measure, ProgressCallback, SupervisorLoop
from mission.runtime.operator import CommandQueue, Commands
from mission.runtime.preflight import Preflight, operator_stop
from mission.runtime.pylog import LogCapture, LogCaptureFactory, RunLogCapture
from mission.runtime.recorder import RunRecorder
from mission.runtime.requests import OperatorRequests, Poller
from mission.runtime.result import RunResult, SupervisorOptions
from mission.runtime.safety import SafetyMonitor
from mission.runtime.samples import LogSamples
from mission.runtime.schedule import make_schedule
from mission.runtime.steps import BaseSteps
from mission.runtime.trees import TreeFactory, TreeRunner
from mission.runtime.truth import TruthTracker
from mission.runtime.viz import VizRecorder

__all__ = ["RunResult", "Supervisor", "SupervisorOptions"]


#: Where in their period the log jobs run (fraction of it), so that not every slow job lands
#: on the tree tick's step: the 3D view (/tf, 10 Hz) at step 2 of each 10. The KCL telemetry
#: and the device log stay with the tree tick and the vehicle KCL: `maris log summary` dates
#: action switches from the former, `maris calibrate` pairs logged commands and readings
#: of the latter with the vehicle steps (the telemetry is taken there; its message is built
#: and written at the next step, with the tree step's time: RunRecorder.kcl). The devices'
#: health poll stays on the tree step too: off it, in a field run, the pacer's wake-ups came
#: late more often (docs/performance.md).
#: Real drivers compute it between the steps instead, for the tree step: ``Backend.prefetch_health``.
LOG_OFFSETS = {"tf_log": 0.2}


def geofence_target(safety: Any) -> np.ndarray | None:
    """The mission's geofence (``safety.geofence``, world NED, m) as the controller's
    ``geofence`` target ``[[n0, n1], [e0, e1], [d0, d1]]``; None without one."""
    fence = getattr(safety, "geofence", None)
    if fence is None:
        return None
    return np.array([fence.north_m, fence.east_m, fence.down_m], dtype=float)


class Supervisor:
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
        measure: Measure,
        blackboard: Any = None,
        log: Any = None,
        model: Any = None,
        mission: Any = None,
        options: SupervisorOptions | None = None,
        commands: Commands | None = None,
        pollers: list[Poller] | None = None,
        on_progress: ProgressCallback | None = None,
        on_event: Callable[[Event], None] | None = None,
        log_capture: LogCaptureFactory = LogCapture,
    ) -> None:
        """``controller``: a :class:`kcl.controller.UvmsController`; ``rates`` and ``safety``:
        the mission's (:class:`mission.spec.Rates`, :class:`mission.spec.Safety`).
        ``log_capture(emit)``: the capture of Python logging records (drivers' warnings)
        into events, :class:`mission.runtime.pylog.LogCapture`; the input record of a
        run wraps it, a replay serves the logged records (:mod:`mission.replay`)."""
        self.backend = backend
        self._log_capture = log_capture
        self.clock = backend.clock
        self.devices = backend.devices
        self.controller = controller
        self.options = o = options or SupervisorOptions()
        self.model = model
        self.commands: Commands = commands or CommandQueue()
        self.on_progress = on_progress
        self.safety = safety
        limits = (model.joint_lower, model.joint_upper) if model is not None else None
        self.monitor = SafetyMonitor(safety, o.velocity_watchdog_s, limits)
        self.rec = RunRecorder(log)
        self.events = EventSink(self.clock)
        self.events.listeners.append(self._log_event)
        if on_event is not None:
            self.events.listeners.append(on_event)
        self.ctx = RuntimeContext(
            self.clock, self.devices, controller, blackboard, self.events, mission=mission, model=model
        )
        self.lifecycle = Lifecycle(self._state_changed)
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
        self.steps = BaseSteps(backend, self.schedule)
        self.dt = self.steps.dt
        #: Start of the run (backend clock, s), set by :meth:`run`.
        self.t0 = 0.0
        self.act = Actuation(self.devices, controller, self.clock, self.events)
        self.poller = DevicePoller(self.clock, self.devices, self.monitor, self.rec)
        self.truth = TruthTracker(backend, self.events, self.rec)
        self.viz = VizRecorder(
            log, model, mission=mission, backend=backend, joint_names=getattr(self.devices.arm, "joint_names", ())
        )
        self.samples = LogSamples(self.rec, self.viz, self.truth, self.ctx, self.act, self.events)
        self.altitude_watch = AltitudeFloorWatch(getattr(safety, "min_altitude_m", 0.0), self.events)
        self.trees = TreeRunner(make_tree, make_abort_tree, self.ctx, self.rec, raise_errors=o.raise_internal_errors)
        self.safe_stop = SafeStop(self.act, self.clock, self.steps, self.samples, o.settle_s)
        self.endings = Endings(self.lifecycle, self.events, self.ctx, self.trees, self.safe_stop, o)
        self.requests = OperatorRequests(
            self.commands, list(pollers or []), self.lifecycle, self.events, self.ctx, self.trees, self.endings
        )
        self._pylog: RunLogCapture | None = None
        self.loop = SupervisorLoop(
            LoopParts(
                backend=backend,
                ctx=self.ctx,
                lifecycle=self.lifecycle,
                steps=self.steps,
                trees=self.trees,
                endings=self.endings,
                requests=self.requests,
                monitor=self.monitor,
                poller=self.poller,
                altitude_watch=self.altitude_watch,
                act=self.act,
                rec=self.rec,
                samples=self.samples,
                measure=measure,
                options=o,
                drain_pylog=self.pylog_drain,
                on_progress=on_progress,
            )
        )
        #: Wall time (s) of :meth:`run`.
        self.wall_s = 0.0

    # ------------------------------------------------------------------ API
    def request(self, command: str, source: str = "api") -> None:
        """Ask for ``pause``, ``resume``, ``toggle``, ``abort`` or ``stop_now``."""
        self.commands.put(command, source)

    @property
    def failure_cause(self) -> str | None:
        """Why the run did not succeed (None while it may still)."""
        return self.endings.failure_cause

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
        endings, lifecycle = self.endings, self.lifecycle
        try:
            lifecycle.go("start")
            stop = None
            try:
                self.backend.open()
            except Exception as exc:  # noqa: BLE001 - e.g. a CAN interface or serial port missing
                problems = [f"cannot open the devices: {type(exc).__name__}: {exc}"]
            else:
                outcome = Preflight(
                    self.ctx,
                    self.backend,
                    self.options,
                    self.commands,
                    self.poller,
                    self.act,
                    self.events,
                    dt=self.dt,
                    drain_pylog=self.pylog_drain,
                ).run()
                problems, stop = outcome.problems, outcome.stop
            if stop is None and not problems:
                self.trees.build()  # the abort path too: a broken one shows before motion
                stop = operator_stop(self.commands)  # one that came while the trees were built
                if stop is None:
                    problems = self.act.engage()  # confirmed arming, or why not
            if stop is not None:  # asked to stop before anything was armed or enabled
                endings.failure_cause = f"operator stop before engagement ({stop.source})"
                self.events.emit(
                    "operator",
                    f"{stop.command} ({stop.source}) before engagement: nothing armed or enabled",
                    level="warning",
                    command=stop.command,
                    source=stop.source,
                )
                lifecycle.go("abort", endings.failure_cause)
                lifecycle.go("abort_done", endings.failure_cause)
            elif problems:
                endings.failure_cause = "preflight: " + "; ".join(problems)
                self.events.emit("preflight", endings.failure_cause, level="fault")
                lifecycle.go("preflight_failed", endings.failure_cause)
            else:
                fence = geofence_target(self.safety)
                if fence is not None:  # every action with the geofence task keeps the vehicle inside
                    self.controller.set_targets(geofence=fence)
                self.altitude_watch.start(self.devices.vehicle.navigation())
                if self.viz.active:
                    self.viz.start(self.clock.now(), self.devices.vehicle.navigation(), self.devices.arm.joint_state())
                lifecycle.go("preflight_ok")
                self.loop.run(self.t0)
                self.altitude_watch.end()
            self.act.disengage()
            self.samples.final_commands()
            self.pylog_drain()
        except Exception as exc:  # noqa: BLE001 - a software fault must still stop the vehicle
            cause = endings.failure_cause = f"internal error: {type(exc).__name__}: {exc}"
            self.events.emit("internal_error", cause, level="fault", traceback=traceback.format_exc())
            self.act.safe_stop_all()
            try:
                self.safe_stop.settle()  # zero commands while the vehicle comes to rest, logged
            except Exception as settle_exc:  # noqa: BLE001 - keep going to the disarm
                self.events.emit("safe_stop", f"settle after the error failed: {settle_exc}", level="fault")
            self.act.disengage()
            if not lifecycle.finished:
                if lifecycle.state == "aborting":
                    lifecycle.go("end_failed", cause)
                elif lifecycle.can("fail"):
                    lifecycle.go("fail", cause)
                elif lifecycle.can("preflight_failed"):
                    lifecycle.go("preflight_failed", cause)
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

    # -------------------------------------------------------------- logging
    def _log_event(self, ev: Event) -> None:
        self.rec.event(ev)
        self.viz.event(ev)

    def _state_changed(self, previous: str, state: str, trigger: str, reason: str) -> None:
        self.rec.state(self.clock.now(), previous, state, trigger, reason)
        if self.on_progress is not None:
            self.on_progress(self.clock.now() - self.t0, state, self.trees.current_action(), self.trees.leaf)

    # --------------------------------------------------------------- result
    def _result(self) -> RunResult:
        """The :class:`RunResult` of the run in its current (final) state."""
        state = self.lifecycle.state
        outcome = state if state in ("succeeded", "failed", "aborted") else "failed"
        truth_msg = self.truth.final()
        duration = self.clock.now() - self.t0
        loop, backend = self.loop, self.backend
        metrics = {
            "closest_to_limits": dict(self.monitor.closest),
            "closest_to_limits_t": dict(self.monitor.closest_t),
            "min_tool_to_target_m": self.truth.min_tool_to_target,
            "final_tool_to_target_m": truth_msg.get("tool_to_target_m"),
            "t0": self.t0,  # backend time of the run start (event times are backend times)
            "steps": self.steps.index,
            "wall_s": self.wall_s,
            "realtime_factor": duration / self.wall_s if self.wall_s > 0 else None,
            "phase_wall_s": dict(loop.phase_wall_s),
            "realtime": bool(getattr(backend, "realtime", False)),
            "wall_overrun_steps": loop.overrun_steps,
            "wall_max_step_s": loop.max_step_compute_s,
            "wall_step_work": loop.step_times.summary(self.dt),
            "wall_slowest_steps": loop.step_times.slowest(),
            "loop_imports": list(loop.loop_imports),
            "fault_count": sum(1 for e in self.events.events if e.level == "fault"),
        }
        timing = getattr(backend, "timing", None)
        if callable(timing):  # real time: the loop's missed deadlines and wake-up lateness (hal.drivers.realtime)
            metrics["wall_ticks"] = timing(loop.loop_tick0)
            metrics["wall_latency"] = loop.step_times.latency_summary(self.t0)
        metrics["wall_gc"] = loop.gc.summary()
        flushes = loop.log_flush.summary()
        if flushes is not None:  # the log's flushes, after the work of their steps (mission.runtime.logflush)
            metrics["wall_log_flush"] = flushes
        served = getattr(backend, "health_served", None)
        if isinstance(
            served, dict
        ):  # real drivers: health polls computed between the steps (hal.drivers.health_prefetch)
            metrics["wall_health_prefetch"] = dict(served)
        if self.options.process is not None:
            metrics["wall_process"] = dict(self.options.process)
        for key in ("vehicle_speed", "vehicle_rate", "tool_axis_error_rad"):
            if truth_msg.get(key) is not None:
                metrics["final_" + key] = truth_msg[key]
        return RunResult(
            outcome=outcome,
            duration_s=duration,
            failure_cause=None if outcome == "succeeded" else (self.endings.failure_cause or "unknown"),
            grasp=truth_msg.get("grasp"),
            log_path=self.rec.path,
            actions=[(s.t - self.t0, s.action) for s in self.trees.switches],
            metrics=metrics,
            events=list(self.events.events),
        )

    def _write_result(self, result: RunResult) -> None:
        d = result.to_dict()
        d.pop("log_path", None)
        self.rec.result(self.clock.now(), d)
