"""The supervisor's preflight: before anything is armed or enabled.

:func:`preflight` steps the backend with zero commands until the devices are
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

from dataclasses import dataclass, field
from typing import Any

RESET_HINT = (
    "reset drive faults with `maris run --reset-faults` (or `maris hal check --reset-faults`) "
    "once the cause is understood; see docs/faults.md"
)


@dataclass
class PreflightOutcome:
    problems: list[str] = field(default_factory=list)
    #: Set when the operator asked to stop before engagement: (command, source).
    stop: tuple[str, str] | None = None


def operator_stop(commands: Any) -> tuple[str, str] | None:
    """Take an ``abort``/``stop_now`` from the queue (other commands stay queued)."""
    stop = None
    keep = []
    for cmd, source in commands.drain():
        if cmd in ("abort", "stop_now") and stop is None:
            stop = (cmd, source)
        else:
            keep.append((cmd, source))
    for cmd, source in keep:
        commands.put(cmd, source)
    return stop


def preflight(sup: Any) -> PreflightOutcome:
    """Run the preflight for supervisor ``sup`` (see the module docstring)."""
    from hal.joints import joint_mismatch

    out = PreflightOutcome()
    devices = sup.devices
    if sup.model is not None:
        why = joint_mismatch(list(devices.arm.joint_names), list(sup.model.joint_names))
        if why:
            out.problems.append(f"arm joints do not match the model: {why}")
            return out
    if sup.options.reset_faults:
        for role, dev in devices.by_role().items():
            if hasattr(dev, "reset_faults"):
                for text in dev.reset_faults():
                    sup.events.emit("fault_reset", f"{role}: reset {text}", level="warning", role=role)
    o = sup.options
    deadline = sup.clock.now() + (o.realtime_preflight_timeout_s if sup.backend.realtime else o.preflight_timeout_s)
    while True:
        sup.pylog_drain()
        out.stop = operator_stop(sup.commands)
        if out.stop is not None:
            return out
        problems = sup.poller.preflight_problems()
        if not problems or sup.clock.now() >= deadline:
            break
        sup.act.zero()
        sup.backend.advance(sup.dt)
    faulted = [
        role
        for role, dev in devices.by_role().items()
        if hasattr(dev, "reset_faults") and not dev.health().state.usable
    ]
    if faulted and not sup.options.reset_faults:
        problems.append(RESET_HINT)
    out.problems = problems
    return out
