"""The supervisor's preflight: before anything is armed or enabled.

:class:`Preflight` steps the backend with zero commands until the devices are
healthy and navigation is valid (or ``preflight_timeout_s``, in real time
``realtime_preflight_timeout_s``, passes) and returns
what still stands in the way. On the way it:

* checks the arm's joints against the model (count and names, in order:
  :func:`hal.joints.joint_mismatch`);
* with ``reset_faults``, first resets drive faults (devices with a
  ``reset_faults()`` method: the CANopen arm and gripper), logging each fault's
  own description (EMCY code and error register, decoded) as a
  ``fault_reset`` event; without it, a faulted drive is a problem whose text
  says how to reset it (docs/faults.md);
* refuses to start while a configured device or vehicle part was not heard
  since the start (health MISSING, :func:`hal.check.unheard`) and its loss
  would only be a warning in the fault table (a DVL, the Ping, the detector:
  losing one later is the table's business, but starting without it is the
  operator's decision), naming its HAL config entry; those the operator allows
  (``allow_missing``, ``maris run --allow-missing``) are logged as
  ``allowed_missing`` warning events instead;
* honours an operator stop (``abort`` / ``stop_now``, e.g. SIGINT) at once: the
  run then ends without engaging anything.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

from hal.check import Unheard, unheard
from hal.interfaces import Backend, DeviceSet
from hal.joints import joint_mismatch
from mission.runtime.actuation import Actuation
from mission.runtime.context import EventSink, RuntimeContext
from mission.runtime.inputs import DevicePoller
from mission.runtime.operator import Commands, OperatorCommand
from mission.runtime.result import SupervisorOptions
from mission.runtime.safety import classify_health

RESET_HINT = (
    "reset drive faults with `maris run --reset-faults` (or `maris hal check --reset-faults`) "
    "once the cause is understood; see docs/faults.md"
)


@dataclass
class PreflightOutcome:
    problems: list[str] = field(default_factory=list)
    #: Set when the operator asked to stop before engagement.
    stop: OperatorCommand | None = None


def operator_stop(commands: Commands) -> OperatorCommand | None:
    """Take an ``abort``/``stop_now`` from the queue (other commands stay queued)."""
    stop = None
    keep = []
    for cmd, source in commands.drain():
        if cmd in ("abort", "stop_now") and stop is None:
            stop = OperatorCommand(cmd, source)
        else:
            keep.append((cmd, source))
    for cmd, source in keep:
        commands.put(cmd, source)
    return stop


def missing_at_start(devices: DeviceSet) -> list[Unheard]:
    """Devices and vehicle parts not heard since the start whose loss the fault table
    only warns about (the others are preflight problems through their health already)."""
    out: list[Unheard] = []
    for role, dev in devices.by_role().items():
        h = dev.health()
        warned = {b.source for b in classify_health(role, h) if b.ending == "warn"}
        out += [u for u in unheard(role, h) if u.name in warned]
    return out


def config_entry(u: Unheard, entries: dict[str, str]) -> str:
    """Where ``u`` is configured (``file:line:column: devices...``), as far as known."""
    return entries.get(u.name) or entries.get(u.role) or f"devices.{u.role}"


class Preflight:
    """The preflight of one run (see the module docstring)."""

    def __init__(
        self,
        ctx: RuntimeContext,
        backend: Backend,
        options: SupervisorOptions,
        commands: Commands,
        poller: DevicePoller,
        act: Actuation,
        events: EventSink,
        *,
        dt: float,
        drain_pylog: Callable[[], None],
    ) -> None:
        """``dt``: the base step (s) the backend advances by while waiting."""
        self.ctx = ctx
        self.backend = backend
        self.options = options
        self.commands = commands
        self.poller = poller
        self.act = act
        self.events = events
        self.dt = dt
        self.drain_pylog = drain_pylog

    def run(self) -> PreflightOutcome:
        """What still stands in the way of the engagement (nothing: ready), or the operator's stop."""
        out = PreflightOutcome()
        devices, model, o = self.ctx.devices, self.ctx.model, self.options
        clock = self.ctx.clock
        if model is not None:
            why = joint_mismatch(list(devices.arm.joint_names), list(model.joint_names))
            if why:
                out.problems.append(f"arm joints do not match the model: {why}")
                return out
        if o.reset_faults:
            for role, dev in devices.by_role().items():
                if hasattr(dev, "reset_faults"):
                    for text in dev.reset_faults():
                        self.events.emit("fault_reset", f"{role}: reset {text}", level="warning", role=role)
        deadline = clock.now() + (o.realtime_preflight_timeout_s if self.backend.realtime else o.preflight_timeout_s)
        while True:
            self.drain_pylog()
            out.stop = operator_stop(self.commands)
            if out.stop is not None:
                return out
            problems = self.poller.preflight_problems() + self.missing_problems()
            if not problems or clock.now() >= deadline:
                break
            self.act.zero()
            self.backend.advance(self.dt)
        faulted = [
            role
            for role, dev in devices.by_role().items()
            if hasattr(dev, "reset_faults") and not dev.health().state.usable
        ]
        if faulted and not o.reset_faults:
            problems.append(RESET_HINT)
        out.problems = problems
        if not problems:
            self.log_allowed_missing()
        return out

    def missing_problems(self) -> list[str]:
        """The devices not heard since the start that the operator did not allow to be missing."""
        o = self.options
        return [
            f"{u.name} not heard since the start ({u.detail}; configured at {config_entry(u, o.config_entries)}): "
            f"start without it with --allow-missing {u.name}"
            for u in missing_at_start(self.ctx.devices)
            if u.name not in o.allow_missing
        ]

    def log_allowed_missing(self) -> None:
        """One ``allowed_missing`` warning event per allowed device still not heard."""
        o = self.options
        for u in missing_at_start(self.ctx.devices):
            if u.name in o.allow_missing:
                self.events.emit(
                    "allowed_missing",
                    f"{u.name} not heard since the start ({u.detail}; configured at "
                    f"{config_entry(u, o.config_entries)}): starting without it, as the operator allowed "
                    f"(--allow-missing {u.name})",
                    level="warning",
                    summary=True,
                    device=u.name,
                    role=u.role,
                )
