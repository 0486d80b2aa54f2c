"""``teleop`` leaf: the operator drives, under the KCL's safety tasks, until they hand back.

While it runs, the operator's commands (the HAL's operator inputs: a gamepad,
the Foxglove live view, the terminal's keys) become the targets of an action
whose operator task sits below the safety tasks (geofence, altitude, tool
clearance, attitude, joint limits), so whatever the operator asks, the safety
tasks hold. The modes, each one action of the actions file:

* ``tool_velocity``: the tool follows the operator's twist, in world (NED) or
  vehicle axes (``frame``; the ``frame:toggle`` button switches), the vehicle
  moving only where the arm alone cannot (``jog_tool`` / ``jog_tool_vehicle``);
* ``vehicle_velocity``: the vehicle follows the operator's body velocity, the
  arm held (``jog_vehicle``);
* ``vehicle_goal``: the vehicle goes to a clicked pose (north, east, heading;
  its depth kept for a click on the 3D view's ground plane) with the arm held
  (``lift``);
* ``tool_goal``: the tool goes to a clicked point, its orientation kept
  (``reach``);
* ``point_at``: the stereo camera turns to a clicked point (on the bottom below
  a ground-plane click), and the detector is told where to search (a click in
  the camera image, or that point: ``TargetDetector.seed_search``) (``look_at``).

A goal mode without a goal holds still (``hold``). The operator changes mode
with a ``mode:<mode>`` press (``mode:next`` cycles), among the node's
``modes``.

Dead-man and latency: a velocity command acts only while it is younger than
``deadman_s`` (its stamp: when the operator gave it) and the input's enabling
switch is held (a gamepad's dead-man button); otherwise the command is zero,
at the next tick. One that arrives older than ``deadman_s`` (a slow link) is
dropped and said so. Goals are taken when younger than ``goal_max_age_s`` and
given after the leaf started; they stay until replaced, so a link with seconds
of delay is driven with goals (``docs/teleop.md``). Among several inputs, the
freshest usable command wins (``teleop_input`` says which).

Hand-back: a ``handback`` press on any input (``button``), the live view's
``/operator/handback`` service (``service``), or ``until`` holding: SUCCESS,
the controller then holds still (``hold``) for the next leaf. ``timeout_s``:
FAILURE (halt contract: motion stopped).

Events: ``control`` (who has control, and how it came back), ``teleop_mode``,
``teleop_input``, ``teleop_deadman``, ``teleop_dropped``, ``teleop_goal``,
``teleop_seed``, ``teleop_limited`` (which safety task holds the operator's
task back, from the controller's ``limited``). The status at each tick goes to
``ctx.operator`` (the log's ``/operator/teleop``).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from py_trees.common import Status

from hal.interfaces import OperatorInput, OperatorSample, SearchSeed, Stamped
from kcl.telemetry import controller_status

from .base import MissionLeaf
from .context import MissionContext
from .operator_frames import UnknownFrame, WorldPoint, to_world
from .predicates import PredicateEval

VELOCITY_MODES = ("tool_velocity", "vehicle_velocity")
GOAL_MODES = ("vehicle_goal", "tool_goal", "point_at")
MODES = VELOCITY_MODES + GOAL_MODES
#: mode -> the action of the actions file it runs (the tool jog: by its axes)
DEFAULT_ACTIONS: dict[str, str] = {
    "tool_velocity": "jog_tool",
    "tool_velocity/vehicle": "jog_tool_vehicle",
    "vehicle_velocity": "jog_vehicle",
    "vehicle_goal": "lift",
    "tool_goal": "reach",
    "point_at": "look_at",
    "idle": "hold",
}
#: what each mode takes from an input: the sample fields, in order of preference
MODE_COMMANDS: dict[str, tuple[str, ...]] = {
    "tool_velocity": ("velocity",),
    "vehicle_velocity": ("velocity",),
    "vehicle_goal": ("pose", "point"),
    "tool_goal": ("point", "pose"),
    "point_at": ("image_point", "point", "pose"),
}
#: ticks (1 s at 10 Hz) a new set of limiting tasks must last before it is reported: no flicker
#: when a task hovers at the 90 % line or an inequality task touches its band for a moment
LIMITED_TICKS = 10


@dataclass(frozen=True)
class HandBack:
    """How the operator gives control back: a ``handback`` press on any input, the live
    view's ``/operator/handback`` service, or a condition becoming true."""

    button: bool = True
    service: bool = True
    until: PredicateEval | None = None

    def describe(self) -> str:
        ways = [w for w, on in (("the handback button", self.button), ("the handback service", self.service)) if on]
        if self.until is not None:
            ways.append(f"`{self.until.describe()}` holding")
        return " or ".join(ways)


@dataclass(frozen=True)
class TeleopSettings:
    """A ``teleop`` node's fields (see the module docstring)."""

    modes: tuple[str, ...] = MODES
    start_mode: str | None = None
    #: operator input roles the node listens to (None: every one present)
    inputs: tuple[str, ...] | None = None
    #: axes of the tool jog: ``world`` (NED) or ``vehicle`` (FRD)
    frame: str = "vehicle"
    deadman_s: float = 0.5
    goal_max_age_s: float = 10.0
    timeout_s: float | None = None
    handback: HandBack = field(default_factory=HandBack)
    actions: Mapping[str, str] = field(default_factory=lambda: dict(DEFAULT_ACTIONS))


@dataclass
class _Input:
    """What the leaf knows of one operator input."""

    role: str
    device: OperatorInput
    presses: dict[str, int] = field(default_factory=dict)
    #: stamp (s) of the last goal-like command taken or refused, per field
    seen: dict[str, float] = field(default_factory=dict)
    #: stamp of the last velocity command seen, and whether it was dropped as too old
    velocity_t: float = -math.inf
    dropping: bool = False


class Teleop(MissionLeaf):
    """The operator drives until they hand back (see the module docstring)."""

    def __init__(self, name: str, ctx: MissionContext, settings: TeleopSettings) -> None:
        super().__init__(name, ctx)
        self.settings = settings
        self._reset()

    def _reset(self) -> None:
        self._t0 = 0.0
        self._inputs: list[_Input] = []
        self._mode = self.settings.start_mode or self.settings.modes[0]
        self._frame = self.settings.frame
        self._action: str | None = None
        self._driver: str | None = None  # role whose command moves the system now
        self._moving = False
        self._velocity = np.zeros(6)
        self._goal: dict[str, Any] | None = None
        self._limited: dict[str, dict[str, Any]] = {}
        self._limited_by: tuple[str, ...] = ()
        self._limited_new: tuple[tuple[str, ...], int] = ((), 0)
        self._dropped = 0
        self._start_error: str | None = None

    # ------------------------------------------------------------------ life cycle
    def initialise(self) -> None:
        self._reset()
        s = self.settings
        self._t0 = self.ctx.now()
        present = self.ctx.devices.operators
        roles = list(s.inputs) if s.inputs is not None else list(present)
        missing = [r for r in roles if r not in present]
        if missing or not roles:
            self._start_error = (
                f"no operator input {', '.join(missing)} on this vehicle"
                if missing
                else "no operator input on this vehicle (a gamepad, the Foxglove live view or the keyboard)"
            )
            return
        for role in roles:
            inp = _Input(role, present[role])
            sample = inp.device.latest()
            if sample is not None:  # presses and commands from before the leaf started do not count
                inp.presses = dict(sample.presses)
                inp.velocity_t = sample.velocity.t if sample.velocity is not None else -math.inf
            self._inputs.append(inp)
        if s.handback.until is not None:
            s.handback.until.reset()
        self.emit(
            "control",
            f"operator has control ({self._mode}; modes {', '.join(s.modes)}; inputs {', '.join(roles)}); "
            f"hand back with {s.handback.describe()}",
            who="operator",
            mode=self._mode,
            modes=list(s.modes),
            inputs=roles,
        )
        self._enter(self._mode, by="mission")

    def update(self) -> Status:
        if self._start_error:
            return self._fail(self._start_error)
        s = self.settings
        now = self.ctx.now()
        elapsed = now - self._t0
        if s.timeout_s is not None and elapsed >= s.timeout_s:
            return self._fail(f"the operator did not hand back within {s.timeout_s:g} s")
        samples = [(inp, inp.device.latest()) for inp in self._inputs]
        handback = self._buttons(samples)
        if handback is not None:
            return self._hand_back(handback)
        if s.handback.until is not None:
            ok, detail = s.handback.until.holds(self.ctx, since=self._t0)
            if ok:
                return self._hand_back(f"`{s.handback.until.describe()}` holds ({detail})")
        if self._mode in VELOCITY_MODES:
            self._drive_velocity(now, samples)
        else:
            self._drive_goal(now, samples)
        self._watch_limits()
        self._report(now)
        self.feedback_message = f"{self._mode}, input {self._driver or 'none'}; {elapsed:.1f} s"
        return Status.RUNNING

    def terminate(self, new_status: Status) -> None:
        board = getattr(self.ctx, "operator", None)
        if board is not None:
            board.status = None
        if self.interrupted(new_status):
            self.ctx.stop_motion()
            self.emit("halted", "teleop interrupted: motion stopped", level="warning")
            self.emit("control", "autonomy has control (teleop interrupted)", who="autonomy", how="interrupted")
        elif new_status == Status.FAILURE:
            self.ctx.stop_motion()

    # ------------------------------------------------------------------ ends
    def _hand_back(self, how: str) -> Status:
        ctrl = self.ctx.controller
        self._clear_operator_targets()
        try:
            ctrl.set_action(self.settings.actions.get("idle", "hold"), self.ctx.now())
        except KeyError:
            self.ctx.stop_motion()
        self.emit("control", f"autonomy has control: handed back by {how}", who="autonomy", how=how)
        self.feedback_message = f"handed back by {how}"
        return Status.SUCCESS

    def _fail(self, why: str) -> Status:
        self.feedback_message = why
        self._clear_operator_targets()
        self.emit("teleop_failed", f"teleop: {why}", level="warning")
        if self._inputs:
            self.emit("control", f"autonomy has control: {why}", who="autonomy", how="failed")
        return Status.FAILURE

    def _clear_operator_targets(self) -> None:
        """The operator's targets go: zero velocities; goals and the camera target cleared."""
        ctrl = self.ctx.controller
        clear = getattr(ctrl, "clear_targets", None)
        if clear is not None:
            clear()
        ctrl.set_targets(tool_velocity=np.zeros(6), vehicle_velocity=np.zeros(6))

    # ------------------------------------------------------------------ buttons
    def _buttons(self, samples: Sequence[tuple[_Input, OperatorSample | None]]) -> str | None:
        """Apply new presses (mode, frame, stop); the hand-back's description if one came."""
        hb = self.settings.handback
        for inp, sample in samples:
            if sample is None:
                continue
            new = {k: n - inp.presses.get(k, 0) for k, n in sample.presses.items() if n > inp.presses.get(k, 0)}
            inp.presses = dict(sample.presses)
            for button in sorted(new):
                if button == "handback" and hb.button:
                    return f"the {inp.role}'s handback button"
                if button == "service:handback" and hb.service:
                    return f"the {inp.role} handback service"
                if button in ("handback", "service:handback"):
                    self.emit("teleop_refused", f"{button} from {inp.role}: this node does not hand back that way")
                elif button.startswith("mode:"):
                    self._mode_request(button[5:], inp.role)
                elif button == "frame:toggle":
                    self._frame = "world" if self._frame == "vehicle" else "vehicle"
                    self.emit("teleop_mode", f"tool jog in {self._frame} axes ({inp.role})", frame=self._frame)
                    if self._mode == "tool_velocity":
                        self._enter(self._mode, by=inp.role)
                elif button == "stop":
                    if self._goal is not None:
                        self.emit("teleop_goal", f"goal cancelled ({inp.role}): holding still", goal=None)
                        self._goal = None
                        self._enter(self._mode, by=inp.role)
        return None

    def _mode_request(self, mode: str, role: str) -> None:
        modes = self.settings.modes
        if mode == "next":
            mode = modes[(modes.index(self._mode) + 1) % len(modes)]
        if mode not in modes:
            self.emit(
                "teleop_refused",
                f"mode `{mode}` ({role}) is not one of this node's: {', '.join(modes)}",
                level="warning",
            )
            return
        if mode != self._mode:
            self._enter(mode, by=role)

    def _enter(self, mode: str, *, by: str) -> None:
        """Switch to ``mode`` (its action; zero velocity, no goal yet)."""
        previous, self._mode = self._mode, mode
        self._goal = None
        self._velocity = np.zeros(6)
        self._clear_operator_targets()
        action = self._mode_action()
        self._switch(action)
        if by != "mission":
            self.emit("teleop_mode", f"mode {previous} -> {mode} ({by})", mode=mode, previous=previous, by=by)

    def _mode_action(self) -> str:
        acts = self.settings.actions
        if self._mode == "tool_velocity" and self._frame == "vehicle":
            return acts["tool_velocity/vehicle"]
        if self._mode in GOAL_MODES and self._goal is None:
            return acts["idle"]
        return acts[self._mode]

    def _switch(self, action: str) -> None:
        if action != self._action:
            self.ctx.controller.set_action(action, self.ctx.now())
            self._action = action

    # ------------------------------------------------------------------ velocities
    def _drive_velocity(self, now: float, samples: Sequence[tuple[_Input, OperatorSample | None]]) -> None:
        s = self.settings
        best: tuple[float, _Input, np.ndarray] | None = None
        for inp, sample in samples:
            cmd = sample.velocity if sample is not None else None
            if sample is None or cmd is None:
                continue
            if cmd.t > inp.velocity_t:  # a new command: does it come too late?
                inp.velocity_t = cmd.t
                late = now - cmd.t > s.deadman_s and now - sample.t <= s.deadman_s
                if late and not inp.dropping:
                    self._dropped += 1
                    self.emit(
                        "teleop_dropped",
                        f"{inp.role}: a velocity command {now - cmd.t:.2f} s old arrived (limit {s.deadman_s:g} s): "
                        "not used; over a slow link, drive with goals",
                        role=inp.role,
                        age_s=now - cmd.t,
                    )
                inp.dropping = late
            usable = sample.deadman and now - cmd.t <= s.deadman_s and now - sample.t <= s.deadman_s
            if usable and (best is None or cmd.t > best[0]):
                best = (cmd.t, inp, np.asarray(cmd.values, dtype=float))
        driver = best[1].role if best is not None else None
        v = best[2] if best is not None else np.zeros(6)
        moving = bool(np.any(v != 0.0))
        if driver != self._driver:
            if driver is not None:
                what = f"{driver} drives"
            elif any(x is not None and now - x.t <= s.deadman_s and not x.deadman for _, x in samples):
                what = "dead-man released: zero velocity"
            else:
                what = f"no fresh command (dead-man, {s.deadman_s:g} s): zero velocity"
            self.emit("teleop_input", f"{self._mode}: {what}", role=driver)
        elif self._moving and not moving and driver is not None:
            self.emit("teleop_deadman", f"{driver}: command zero", role=driver)
        self._driver, self._moving = driver, moving
        if not np.array_equal(v, self._velocity):
            self._velocity = v.copy()
            key = "tool_velocity" if self._mode == "tool_velocity" else "vehicle_velocity"
            self.ctx.controller.set_targets(**{key: v})

    # ------------------------------------------------------------------ goals
    def _drive_goal(self, now: float, samples: Sequence[tuple[_Input, OperatorSample | None]]) -> None:
        s = self.settings
        newest: tuple[float, _Input, str, Stamped] | None = None
        for inp, sample in samples:
            if sample is None:
                continue
            for name in MODE_COMMANDS[self._mode]:
                cmd: Stamped | None = getattr(sample, name)
                if cmd is None or cmd.t <= inp.seen.get(name, -math.inf):
                    continue
                inp.seen[name] = cmd.t
                if cmd.t < self._t0:
                    continue  # given before the operator had control: not for this session
                age = now - cmd.t
                if age > s.goal_max_age_s:
                    self._dropped += 1
                    self.emit(
                        "teleop_dropped",
                        f"{inp.role}: a {name} {age:.1f} s old arrived (limit {s.goal_max_age_s:g} s): not used",
                        role=inp.role,
                        age_s=age,
                    )
                    continue
                if newest is None or cmd.t > newest[0]:
                    newest = (cmd.t, inp, name, cmd)
        if newest is not None:
            _, inp, name, cmd = newest
            self._take_goal(now, inp.role, name, cmd)
        self._driver = None if self._goal is None else self._goal["role"]

    def _take_goal(self, now: float, role: str, name: str, cmd: Stamped) -> None:
        nav = self.ctx.devices.vehicle.navigation()
        age = now - cmd.t
        if name == "image_point":
            self._seed(SearchSeed(cmd.t, image_point=np.asarray(cmd.values), camera=cmd.frame or "left"), role)
            return
        try:
            wp = to_world(cmd.values, cmd.frame, nav)
        except UnknownFrame as exc:
            self.emit("teleop_refused", f"{role}: {exc}", level="warning", role=role)
            return
        ctrl = self.ctx.controller
        if self._mode == "vehicle_goal":
            z = float(wp.position[2]) if wp.depth_given else float(nav.position[2])
            yaw = wp.yaw if wp.yaw is not None else float(nav.attitude[2])
            goal = np.array([wp.position[0], wp.position[1], z, yaw])
            ctrl.set_targets(vehicle_goal=goal)
        elif self._mode == "tool_goal":
            tool = self._tool_pose(nav)
            if tool is None:
                self.emit("teleop_refused", "tool goal: the controller has no model to place the tool", level="warning")
                return
            T = tool.copy()
            T[:3, 3] = wp.position if wp.depth_given else np.r_[wp.position[:2], tool[2, 3]]
            goal = T
            ctrl.set_targets(tool_goal=T)
        else:  # point_at: the target on the bottom below a ground-plane click
            target = self._on_bottom(wp, nav)
            goal = target
            ctrl.set_targets(camera_target=target)
            self._seed(SearchSeed(cmd.t, point=target.copy()), role)
        point = goal[:3, 3] if self._mode == "tool_goal" else goal  # the tool goal's position, else the goal
        self._goal = {"role": role, "kind": name, "t": cmd.t, "point": np.asarray(point, dtype=float).tolist()}
        self._switch(self.settings.actions[self._mode])
        self.emit(
            "teleop_goal",
            f"{self._mode}: {name} from {role} ({age:.2f} s old): {_describe_goal(self._mode, goal)}",
            role=role,
            mode=self._mode,
            goal=np.asarray(goal).tolist(),
            age_s=age,
        )

    def _on_bottom(self, wp: WorldPoint, nav: Any) -> np.ndarray:
        if wp.depth_given or nav.altitude is None or not math.isfinite(nav.altitude):
            return np.asarray(wp.position, dtype=float)
        return np.r_[wp.position[:2], float(nav.depth) + float(nav.altitude)]

    def _tool_pose(self, nav: Any) -> np.ndarray | None:
        model = getattr(self.ctx.controller, "model", None)
        if model is None:
            return None
        q = np.asarray(self.ctx.devices.arm.joint_state().position, dtype=float)
        eta = np.r_[np.asarray(nav.position, dtype=float), np.asarray(nav.attitude, dtype=float)]
        return np.asarray(model.frame_pose_world(q, eta, "tool"), dtype=float)

    def _seed(self, seed: SearchSeed, role: str) -> None:
        detector = self.ctx.devices.detector
        if detector is None:
            self.emit("teleop_seed", f"{role}: no detector to seed", role=role)
            return
        used = bool(detector.seed_search(seed))
        where = (
            f"pixel {np.round(seed.image_point, 1).tolist()} of the {seed.camera} camera"
            if seed.image_point is not None
            else f"world point {np.round(np.asarray(seed.point), 2).tolist()}"
        )
        self.emit(
            "teleop_seed",
            f"{role}: search seed at {where}" + ("" if used else " (the detector does not use seeds)"),
            role=role,
            used=used,
        )

    # ------------------------------------------------------------------ reports
    def _watch_limits(self) -> None:
        """Report which safety tasks hold the operator's task back (debounced)."""
        ctrl = self.ctx.controller
        fn = getattr(ctrl, "limited", None)
        limited = fn() if fn is not None else dict(ctrl.telemetry().get("limited") or {})
        self._limited = limited
        by = tuple(sorted({b for entry in limited.values() for b in entry.get("by", ())}))
        candidate, count = self._limited_new
        count = count + 1 if by == candidate else 1
        self._limited_new = (by, count)
        if by != self._limited_by and count >= LIMITED_TICKS:
            self._limited_by = by
            if by:
                parts = [
                    f"{task} at {100 * max(0.0, e['ratio']):.0f} % of the command, by {', '.join(e['by'])}"
                    for task, e in sorted(limited.items())
                    if e.get("by")
                ]
                self.emit("teleop_limited", f"safety tasks hold the operator back: {'; '.join(parts)}", by=list(by))
            else:
                self.emit("teleop_limited", "no safety task holds the operator back any more", by=[])

    def _report(self, now: float) -> None:
        board = getattr(self.ctx, "operator", None)
        if board is None:
            return
        status = controller_status(self.ctx.controller)
        board.status = {
            "t": now,
            "control": "operator",
            "node": self.name,
            "mode": self._mode,
            "frame": self._frame,
            "action": status.get("action"),
            "input": self._driver,
            "command": self._velocity.tolist() if self._mode in VELOCITY_MODES else [],
            "goal": [] if self._goal is None else list(self._goal["point"]),
            "limited_by": list(self._limited_by),
            "limited": {k: {"ratio": float(v["ratio"]), "by": list(v["by"])} for k, v in self._limited.items()},
            "dropped": self._dropped,
        }


def _describe_goal(mode: str, goal: Any) -> str:
    g = np.asarray(goal, dtype=float)
    if mode == "vehicle_goal":
        return f"vehicle to north {g[0]:.2f} m, east {g[1]:.2f} m, depth {g[2]:.2f} m, heading {math.degrees(g[3]):.0f} deg"
    if mode == "tool_goal":
        p = g[:3, 3]
        return f"tool to north {p[0]:.2f} m, east {p[1]:.2f} m, depth {p[2]:.2f} m (orientation kept)"
    return f"camera to north {g[0]:.2f} m, east {g[1]:.2f} m, depth {g[2]:.2f} m"


__all__: Sequence[str] = ("GOAL_MODES", "MODES", "VELOCITY_MODES", "HandBack", "Teleop", "TeleopSettings")
