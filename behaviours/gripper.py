"""``gripper`` leaf: open, close with a current limit, or preshape.

The command is sent once in ``initialise``. With ``wait`` (default) the leaf
is RUNNING while the gripper is busy with it and SUCCESS when it is done:

* close: done when the motion is HOLDING (stalled on an object at the current
  limit) or STOPPED (end of travel: closed on nothing; a following
  ``grasp_detected`` condition tells the two apart);
* open / preshape: done when the motion is IDLE or STOPPED, after the busy
  motion was seen or ``settle_s`` passed (a gripper may report IDLE before it
  starts).

FAILURE on a gripper fault or after ``timeout_s`` (the motors are stopped).
Halted while RUNNING, the leaf stops the gripper motors (halt contract for
the hand).
"""

from __future__ import annotations

from py_trees.common import Status

from hal.interfaces import GripperMotion

from .base import MissionLeaf
from .context import MissionContext

BUSY = {"close": GripperMotion.CLOSING, "open": GripperMotion.OPENING, "preshape": GripperMotion.PRESHAPING}
DONE = {
    "close": (GripperMotion.HOLDING, GripperMotion.STOPPED),
    "open": (GripperMotion.IDLE, GripperMotion.STOPPED),
    "preshape": (GripperMotion.IDLE, GripperMotion.STOPPED),
}


class GripperCommand(MissionLeaf):
    """One gripper command (see the module docstring); times in s, current in A."""

    settle_s = 0.5

    def __init__(
        self,
        name: str,
        ctx: MissionContext,
        command: str,
        *,
        shape: str | None = None,
        current_limit_a: float | None = None,
        timeout_s: float | None = None,
        wait: bool = True,
    ) -> None:
        super().__init__(name, ctx)
        if command not in BUSY:
            raise ValueError(f"unknown gripper command {command!r}")
        if command == "close" and current_limit_a is None:
            raise ValueError("a gripper close needs its current limit (current_limit_a)")
        self.command, self.shape, self.current_limit_a = command, shape, current_limit_a
        self.timeout_s, self.wait = timeout_s, wait
        self._t0 = 0.0
        self._seen_busy = False
        self._error: str | None = None

    def initialise(self) -> None:
        self._t0 = self.ctx.now()
        self._seen_busy = False
        self._error = None
        gripper = self.ctx.devices.gripper
        if gripper is None:
            self._error = "no gripper device"
            return
        try:
            if self.command == "close" and self.current_limit_a is not None:  # always set for close
                gripper.close(float(self.current_limit_a))
            elif self.command == "open":
                gripper.open()
            else:
                gripper.preshape(str(self.shape))
        except Exception as exc:  # noqa: BLE001 - a device error is a leaf failure, reported
            self._error = f"gripper {self.command} failed: {exc}"
        self.emit(
            "gripper_command",
            f"gripper {self.command}",
            shape=self.shape,
            current_limit_a=self.current_limit_a,
            t=self._t0,
        )

    def update(self) -> Status:
        if self._error:
            self.feedback_message = self._error
            self.emit("gripper_error", self._error, level="warning")
            return Status.FAILURE
        if not self.wait:
            return Status.SUCCESS
        gripper = self.ctx.devices.gripper
        if gripper is None:  # initialise() found none and failed the leaf above
            return Status.FAILURE
        state = gripper.state()
        if state.fault:
            self.feedback_message = f"gripper fault: {state.fault}"
            self.emit("gripper_error", self.feedback_message, level="warning")
            return Status.FAILURE
        elapsed = self.ctx.now() - self._t0
        self._seen_busy |= state.motion is BUSY[self.command]
        started = self._seen_busy or elapsed >= self.settle_s
        if started and state.motion in DONE[self.command] and state.t >= self._t0:
            self.feedback_message = f"done ({state.motion.value})"
            return Status.SUCCESS
        if self.timeout_s is not None and elapsed >= self.timeout_s:
            self.feedback_message = f"gripper {self.command} timed out after {elapsed:.1f} s ({state.motion.value})"
            self.emit("timeout", self.feedback_message, level="warning")
            return Status.FAILURE
        self.feedback_message = f"{state.motion.value} ({elapsed:.1f} s)"
        return Status.RUNNING

    def terminate(self, new_status: Status) -> None:
        gripper = self.ctx.devices.gripper
        if gripper is None:
            return
        if self.interrupted(new_status):
            try:
                gripper.stop()
            finally:
                self.emit("halted", f"gripper {self.command} interrupted: gripper stopped", level="warning")
        elif new_status == Status.FAILURE and self.status == Status.RUNNING:
            gripper.stop()  # timed out or faulted half-way: do not leave the motors running
