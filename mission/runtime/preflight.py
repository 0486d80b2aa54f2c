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
* honours an operator stop (``abort`` / ``stop_now``, e.g. SIGINT) at once: the
  run then ends without engaging anything.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

from hal.interfaces import Backend
from hal.joints import joint_mismatch
from mission.runtime.actuation import Actuation
from mission.runtime.context import EventSink, RuntimeContext
from mission.runtime.inputs import DevicePoller
from mission.runtime.operator import Commands, OperatorCommand
from mission.runtime.result import SupervisorOptions

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
            problems = self.poller.preflight_problems()
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
        return out
