"""The supervisor's options and the result of one run.

:class:`SupervisorOptions` are the runtime knobs (rates in Hz, times in s of the
backend clock); :class:`RunResult` is what :meth:`mission.runtime.supervisor.Supervisor.run` returns and what
the log's ``/run/result`` holds.
"""

from __future__ import annotations

from dataclasses import dataclass, field

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
    #: Devices (roles) or vehicle parts (``dvl``, ``ahrs``, ``ping``) the run may start without when
    #: they are not heard at preflight (``maris run --allow-missing``); each is logged. Any other
    #: configured device not heard since the start refuses the start.
    allow_missing: tuple[str, ...] = ()
    #: Name (as in ``allow_missing``) -> its HAL config entry (``file:line:column: devices...``),
    #: named by the preflight's messages (:func:`hal.check.config_entries`; filled by ``run_mission``).
    config_entries: dict[str, str] = field(default_factory=dict)
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
