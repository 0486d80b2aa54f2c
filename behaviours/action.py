"""``action`` leaf: run one KCL action until its condition holds.

``initialise`` switches the controller's current action (the KCL blends the
old and new task activations: a smooth transition) and sends the targets.
Each ``update`` (never blocking):

1. fails on the leaf's own ``timeout_s`` (backend clock) or on a controller
   fault lasting ``fault_grace_s``;
2. with ``track_detection``: a detection newer than the last one used, fresh
   and confident, is turned into a world grasp pose (with the vehicle pose at
   the image time, interpolated from the poses seen at earlier ticks) and
   written to its blackboard key. When the tool goal comes from that same key,
   the leaf first clears the controller's targets and sends no tool goal until
   a detection taken after the leaf started has arrived (event
   ``target_acquired``): a retried attempt never closes on the stale goal of
   the attempt before;
3. re-sends ``tool_goal`` / ``camera_target`` when their blackboard values
   changed (so the grasp target follows new detections);
4. follows the vehicle goal or waypoints: a waypoint is reached within
   ``tolerance_m`` and, when it (or an earlier goal) gives ``yaw_deg``, within
   ``yaw_tolerance_deg`` of that heading; ``altitude_m`` goals are re-computed from the measured
   altitude every tick; missing goal fields keep the previous goal's value
   (for the first goal: the vehicle's pose at start);
5. decides: with ``until``, SUCCESS once it holds (FAILURE if the waypoints
   ran out first, unless ``loop``); without ``until``, SUCCESS when the last
   waypoint / the vehicle goal is reached, or else when the controller reports
   the action converged. Convergence counts only from controller steps after
   the leaf started and after the last real target change (vehicle goal, or a
   tool goal moved by more than ``retarget_m`` / ``retarget_rad``; smaller
   moves are vision noise), so a retried action is not finished by its
   previous run's errors.

Halt contract: halted while RUNNING, or failing, the leaf calls
``ctx.stop_motion()`` before returning. On SUCCESS the controller keeps the
action running (the next leaf switches it).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
from py_trees.common import Status

from kcl.telemetry import controller_status

from .base import MissionLeaf
from .context import MissionContext
from .geometry import distance_to_goal, grasp_pose_world, heading_error
from .nav_history import NavHistory
from .predicates import DEFAULT_MAX_ERROR, PredicateEval, fresh_detection, telemetry_converged

Goal = tuple[float, float, float, float]  # x, y, z (world NED, m), yaw (rad)


def resolve_goal(spec: Mapping[str, Any], previous: Goal, depth: float | None, altitude: float | None) -> Goal:
    """World goal (x, y, z, yaw) from a goal spec (``north_m east_m down_m
    altitude_m yaw_deg``, any may be None); missing fields keep ``previous``.

    ``altitude_m`` gives z = bottom depth - altitude_m, with the bottom depth
    measured as ``depth + altitude``; unknown altitude keeps the previous z.
    """
    x = spec.get("north_m")
    y = spec.get("east_m")
    z = spec.get("down_m")
    if (
        z is None
        and spec.get("altitude_m") is not None
        and depth is not None
        and altitude is not None
        and _finite(depth)
        and _finite(altitude)
    ):
        z = depth + altitude - spec["altitude_m"]
    yaw = spec.get("yaw_deg")
    return (
        previous[0] if x is None else float(x),
        previous[1] if y is None else float(y),
        previous[2] if z is None else float(z),
        previous[3] if yaw is None else math.radians(yaw),
    )


def _finite(x: float | None) -> bool:
    return x is not None and math.isfinite(x)


class KclAction(MissionLeaf):
    """Run KCL action ``run`` (see the module docstring for the semantics)."""

    #: A controller fault lasting this long (s) fails the leaf (single-step
    #: faults clear on the next good step; the supervisor watches them too).
    fault_grace_s = 0.5
    #: Convergence threshold when the leaf has no ``until`` (m / rad).
    max_error = DEFAULT_MAX_ERROR
    #: A tool goal update larger than this (m, rad) restarts the convergence
    #: clock; smaller ones are treated as vision noise around the same target.
    retarget_m = 0.05
    retarget_rad = 0.1

    def __init__(
        self,
        name: str,
        ctx: MissionContext,
        run: str,
        *,
        targets: Mapping[str, Any] | None = None,
        until: PredicateEval | None = None,
        timeout_s: float | None = None,
        track_detection: Mapping[str, Any] | None = None,
    ):
        super().__init__(name, ctx)
        self.run = run
        t = dict(targets or {})
        goals = t.get("waypoints") or ([t["vehicle_goal"]] if t.get("vehicle_goal") is not None else [])
        self.goal_specs: list[Mapping[str, Any]] = list(goals)
        self.tolerance_m = float(t.get("tolerance_m") or 0.5)
        self.yaw_tolerance = math.radians(float(t.get("yaw_tolerance_deg") or 10.0))
        self.loop = bool(t.get("loop", False))
        self.tool_goal_from: str | None = t.get("tool_goal_from")
        self.camera_target_from: str | None = t.get("camera_target_from")
        self.until = until
        self.timeout_s = timeout_s
        self.track = dict(track_detection) if track_detection else None
        self._reset()

    def _reset(self) -> None:
        self._t0 = 0.0
        self._index = 0
        self._goal: Goal | None = None
        self._sent: dict[str, Any] = {}
        self._last_detection_t = -math.inf
        self._path_done = False
        self._fault_since: float | None = None
        self._nav_history = NavHistory()
        self._start_error: str | None = None
        self._targets_t = 0.0  # s, last time targets were sent (or the start)
        # the tool goal follows the tracked detections: wait for one taken after the start
        self._await_fresh = self.track is not None and self.tool_goal_from == self.track.get("store_as")

    # ------------------------------------------------------------------ life cycle
    def initialise(self) -> None:
        self._reset()
        self._t0 = self.ctx.now()
        self._start_error = None
        self._targets_t = self._t0
        if self.until is not None:
            self.until.reset()
        try:
            self.ctx.controller.set_action(self.run, self._t0)
        except KeyError:
            self._start_error = f"the controller has no action `{self.run}`"
            return
        if self._await_fresh:
            self.ctx.controller.clear_targets()  # no stale tool goal; the leaf's own targets follow
        if self.goal_specs:
            nav = self.ctx.devices.vehicle.navigation()
            start = (float(nav.position[0]), float(nav.position[1]), float(nav.position[2]), float(nav.attitude[2]))
            if not all(math.isfinite(v) for v in start):
                self._start_error = f"navigation is not finite at start: {start}"
                return
            self._goal = resolve_goal(self.goal_specs[0], start, nav.depth, nav.altitude)
        self._push_targets()
        self.emit("action_start", f"action {self.run} started", action=self.run, t=self._t0)

    def update(self) -> Status:
        if self._start_error:
            return self._fail(self._start_error)
        now = self.ctx.now()
        elapsed = now - self._t0
        if self.timeout_s is not None and elapsed >= self.timeout_s:
            return self._fail(f"timed out after {elapsed:.1f} s (limit {self.timeout_s:g} s)")
        telemetry = controller_status(self.ctx.controller)
        if telemetry.get("fault"):
            if self._fault_since is None:
                self._fault_since = now
            if now - self._fault_since >= self.fault_grace_s:
                return self._fail(
                    f"controller fault for {now - self._fault_since:.1f} s: {telemetry.get('fault_reason') or 'no reason given'}"
                )
        else:
            self._fault_since = None
        if self.track is not None:
            self._track_detection(self.track)
        self._follow_path()
        self._push_targets()
        since = self._targets_t  # only controller steps after the last real target change count
        if self.until is not None:
            ok, detail = self.until.holds(self.ctx, since=since)
            if ok:
                return self._succeed(detail)
            if self._path_done:
                return self._fail(f"waypoints done but `{self.until.describe()}` never held ({detail})")
            wait = "waiting for a fresh detection; " if self._await_fresh else ""
            self.feedback_message = f"{wait}{detail}; {elapsed:.1f} s"
            return Status.RUNNING
        if self.goal_specs:
            if self._path_done:
                return self._succeed("goal reached")
        elif telemetry_converged(telemetry, self.run, self.max_error, since=since):
            return self._succeed("converged")
        self.feedback_message = f"running {elapsed:.1f} s"
        return Status.RUNNING

    def terminate(self, new_status: Status) -> None:
        if self.interrupted(new_status):
            self.ctx.stop_motion()
            self.emit("halted", f"action {self.run} interrupted: motion stopped", action=self.run, level="warning")
        elif new_status == Status.FAILURE:  # the action may be half-started: stop it
            self.ctx.stop_motion()

    # ------------------------------------------------------------------ helpers
    def _succeed(self, detail: str) -> Status:
        self.feedback_message = detail
        self.emit("action_success", f"action {self.run}: {detail}", action=self.run, t=self.ctx.now())
        return Status.SUCCESS

    def _fail(self, why: str) -> Status:
        self.feedback_message = why
        self.emit("action_failure", f"action {self.run}: {why}", action=self.run, t=self.ctx.now(), level="warning")
        return Status.FAILURE

    def _track_detection(self, track: Mapping[str, Any]) -> None:
        """Keep the latest fresh detection of ``track`` (the action's ``track_detection``) on the blackboard."""
        nav = self.ctx.devices.vehicle.navigation()
        self._nav_history.add(nav)
        det = fresh_detection(self.ctx, track["min_confidence"], track["max_age_s"])
        if det is not None and det.t > self._last_detection_t:
            self._last_detection_t = det.t
            self.ctx.blackboard.set(track["store_as"], grasp_pose_world(nav, det, self._nav_history))
            if self._await_fresh and det.t >= self._t0:
                self._await_fresh = False
                self.emit(
                    "target_acquired",
                    f"action {self.run}: fresh detection, tool goal set",
                    action=self.run,
                    image_t=det.t,
                    wait_s=self.ctx.now() - self._t0,
                )

    def _follow_path(self) -> None:
        """Update the vehicle goal; sets ``_path_done`` when the last goal is reached."""
        if not self.goal_specs or self._goal is None or self._path_done:
            return
        nav = self.ctx.devices.vehicle.navigation()
        spec = self.goal_specs[self._index]
        if spec.get("altitude_m") is not None:
            self._goal = resolve_goal(spec, self._goal, nav.depth, nav.altitude)
        if distance_to_goal(nav, np.array(self._goal[:3])) > self.tolerance_m:
            return
        if self._heading_given(self._index) and heading_error(nav, self._goal[3]) > self.yaw_tolerance:
            return  # a goal with a heading is reached only when the heading is too
        last = self._index == len(self.goal_specs) - 1
        if last and not self.loop:
            self._path_done = True
            return
        self._index = 0 if last else self._index + 1
        self._goal = resolve_goal(self.goal_specs[self._index], self._goal, nav.depth, nav.altitude)
        self.emit("waypoint", f"heading to waypoint {self._index + 1} of {len(self.goal_specs)}", goal=list(self._goal))

    def _heading_given(self, index: int) -> bool:
        """True when goal ``index`` (or an earlier one it inherits from) sets ``yaw_deg``."""
        return any(spec.get("yaw_deg") is not None for spec in self.goal_specs[: index + 1])

    def _push_targets(self) -> None:
        """Send targets whose value changed since last sent (set_targets kwargs).

        A vehicle goal change, or a tool goal moved by more than
        ``retarget_m`` / ``retarget_rad``, restarts the convergence clock
        (``_targets_t``); smaller tool goal updates (vision noise) do not.
        """
        changes: dict[str, Any] = {}
        jump = False
        if self._goal is not None and self._sent.get("vehicle_goal") != self._goal:
            changes["vehicle_goal"] = self._goal
            jump = True
        for kwarg, key in (("tool_goal", self.tool_goal_from), ("camera_target", self.camera_target_from)):
            if key is None or (kwarg == "tool_goal" and self._await_fresh):
                continue
            value = self.ctx.blackboard.get(key)
            previous = self._sent.get(kwarg)
            if value is None or value is previous:
                continue
            if kwarg == "camera_target" and np.shape(value) == (4, 4):
                changes[kwarg] = np.asarray(value)[:3, 3]
            else:
                changes[kwarg] = value
            if kwarg == "tool_goal":
                jump = jump or previous is None or moved_beyond(previous, value, self.retarget_m, self.retarget_rad)
            self._sent[kwarg] = value
        if changes:
            if "vehicle_goal" in changes:
                self._sent["vehicle_goal"] = changes["vehicle_goal"]
            self.ctx.controller.set_targets(**changes)
            if jump:
                self._targets_t = self.ctx.now()


def moved_beyond(a: np.ndarray, b: np.ndarray, limit_m: float, limit_rad: float) -> bool:
    """True if 4x4 poses ``a`` and ``b`` differ by more than ``limit_m`` in
    translation or ``limit_rad`` in rotation angle."""
    a, b = np.asarray(a, float), np.asarray(b, float)
    if float(np.linalg.norm(a[:3, 3] - b[:3, 3])) > limit_m:
        return True
    cos = (np.trace(a[:3, :3].T @ b[:3, :3]) - 1.0) / 2.0
    return float(np.arccos(np.clip(cos, -1.0, 1.0))) > limit_rad


__all__: Sequence[str] = ("KclAction", "moved_beyond", "resolve_goal")
