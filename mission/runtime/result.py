"""The supervisor's options and the result of one run.

:class:`SupervisorOptions` are the runtime knobs (rates in Hz, times in s of the
backend clock); :class:`RunResult` is what :meth:`Supervisor.run` returns and what
the log's ``/run/result`` holds.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

from mission.runtime.context import Event


@dataclass
class SupervisorOptions:
    """Runtime knobs (rates in Hz, times in s of backend clock)."""

    kcl_log_hz: float = 10.0
    device_log_hz: float = 20.0
    ground_truth_log_hz: float = 10.0
    #: Rate of the 3D frame tree (/tf) and named joints (/arm/joints) in the log.
    tf_log_hz: float = 10.0
    preflight_timeout_s: float = 2.0
    #: Preflight limit on real-time backends: real links need time to connect, hear the
    #: first heartbeat and receive the telemetry they asked for (ArduSub: a few seconds).
    realtime_preflight_timeout_s: float = 15.0
    abort_timeout_s: float = 300.0
    #: DVL velocity watchdog (s); see :class:`mission.runtime.safety.SafetyMonitor`.
    velocity_watchdog_s: float = 1.0
    settle_s: float = 3.0
    #: Longest abort path (s) after a fault whose ending is ``abort_short`` (docs/faults.md).
    short_abort_s: float = 10.0
    #: Reset drive faults at preflight (logged with each fault's description) instead of refusing to start.
    reset_faults: bool = False
    #: Hard cap on the loop (backend s); the envelope's max duration normally ends runs first.
    max_time_s: float | None = None
    #: Re-raise software errors after the safe stop (debugging) instead of returning a failed result.
    raise_internal_errors: bool = False
    #: Garbage collector during the loop: ``auto``, ``freeze`` or ``manual`` (:mod:`mission.runtime.rtprocess`).
    gc_mode: str = "auto"
    #: What the process runs with (scheduling, niceness, CPUs), as applied by ``maris run``;
    #: copied into the result's ``wall_process`` metric.
    process: dict | None = None


@dataclass
class RunResult:
    """What a run produced. ``outcome``: succeeded, failed or aborted."""

    outcome: str
    duration_s: float
    failure_cause: str | None = None
    grasp: str | None = None
    log_path: str | None = None
    actions: list[tuple[float, str]] = field(default_factory=list)
    metrics: dict = field(default_factory=dict)
    events: list[Event] = field(default_factory=list)

    @property
    def succeeded(self) -> bool:
        return self.outcome == "succeeded"

    def to_dict(self) -> dict:
        return {
            "outcome": self.outcome,
            "duration_s": self.duration_s,
            "failure_cause": self.failure_cause,
            "grasp": self.grasp,
            "log_path": self.log_path,
            "actions": self.actions,
            "metrics": self.metrics,
        }


def build_result(sup: Any) -> RunResult:
    """The :class:`RunResult` of supervisor ``sup`` in its current (final) state."""
    state = sup.lifecycle.state
    outcome = state if state in ("succeeded", "failed", "aborted") else "failed"
    truth_msg = sup.truth.final()
    duration = sup.clock.now() - sup.t0
    metrics = {
        "closest_to_limits": dict(sup.monitor.closest),
        "closest_to_limits_t": dict(sup.monitor.closest_t),
        "min_tool_to_target_m": sup.truth.min_tool_to_target,
        "final_tool_to_target_m": truth_msg.get("tool_to_target_m"),
        "t0": sup.t0,  # backend time of the run start (event times are backend times)
        "steps": sup.step,
        "wall_s": sup.wall_s,
        "realtime_factor": duration / sup.wall_s if sup.wall_s > 0 else None,
        "phase_wall_s": dict(sup.phase_wall_s),
        "realtime": bool(getattr(sup.backend, "realtime", False)),
        "wall_overrun_steps": sup.overrun_steps,
        "wall_max_step_s": sup.max_step_compute_s,
        "wall_step_work": sup.step_times.summary(sup.dt),
        "wall_slowest_steps": sup.step_times.slowest(),
        "loop_imports": list(sup.loop_imports),
        "fault_count": sum(1 for e in sup.events.events if e.level == "fault"),
    }
    timing = getattr(sup.backend, "timing", None)
    if callable(timing):  # real time: the loop's missed deadlines and wake-up lateness (hal.drivers.realtime)
        metrics["wall_ticks"] = timing(sup.loop_tick0)
        metrics["wall_latency"] = sup.step_times.latency_summary(sup.t0)
    metrics["wall_gc"] = sup.gc.summary()
    flushes = sup.log_flush.summary()
    if flushes is not None:  # the log's flushes, after the work of their steps (mission.runtime.logflush)
        metrics["wall_log_flush"] = flushes
    served = getattr(sup.backend, "health_served", None)
    if isinstance(served, dict):  # real drivers: health polls computed between the steps (hal.drivers.health_prefetch)
        metrics["wall_health_prefetch"] = dict(served)
    if sup.options.process is not None:
        metrics["wall_process"] = dict(sup.options.process)
    for key in ("vehicle_speed", "vehicle_rate", "tool_axis_error_rad"):
        if truth_msg.get(key) is not None:
            metrics["final_" + key] = truth_msg[key]
    return RunResult(
        outcome=outcome,
        duration_s=duration,
        failure_cause=None if outcome == "succeeded" else (sup.failure_cause or "unknown"),
        grasp=truth_msg.get("grasp"),
        log_path=sup.rec.path,
        actions=list(sup._actions),  # noqa: SLF001 - the supervisor's own record
        metrics=metrics,
        events=list(sup.events.events),
    )
