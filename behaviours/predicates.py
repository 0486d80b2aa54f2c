"""Evaluators for mission predicates (``detected``, ``grasp_detected``, ...).

One :class:`PredicateEval` per :class:`mission.spec.Predicate`; ``holds(ctx)``
reads the devices / controller / blackboard once and returns
``(holds, detail)`` (``holds`` always a plain ``bool``, never a numpy
boolean: py_trees' guards accept nothing else), never blocking. They serve ``condition`` leaves, ``guard``
decorators and the ``until`` of action leaves.

Semantics (MARIS):

* ``detected``: the latest detection is fresher than ``max_age_s`` (judged on
  its image time) with confidence >= ``min_confidence``. With ``store_as``,
  the grasp frame (vTg) is turned into a world pose with the vehicle pose at
  the image time (interpolated from the poses seen at earlier evaluations,
  :class:`~behaviours.nav_history.NavHistory`) and written to that key.
* ``grasp_detected``: the gripper reports HOLDING and at least ``min_groups``
  motor groups draw >= ``current_a``.
* ``converged``: the controller's current action converged: every equality
  task error <= ``max_error`` (default 0.02, m / rad) after the transition,
  without interruption for ``for_s`` seconds (default 0).
* ``depth_m`` / ``altitude_m`` / ``force_n``: the measured value lies within
  [min, max] (an unknown value does not hold).
* ``blackboard``: a comparison on a mission key.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from typing import Any

import numpy as np

from hal.interfaces import Detection, GripperMotion
from kcl.telemetry import controller_status

from .context import MissionContext
from .geometry import grasp_pose_world
from .nav_history import NavHistory

Result = tuple[bool, str]


#: Default convergence threshold: largest error norm of the action's equality
#: tasks (task units: m for positions, rad for angles and postures).
DEFAULT_MAX_ERROR = 0.02


def telemetry_converged(
    telemetry: Mapping[str, Any],
    action: str | None = None,
    max_error: float = DEFAULT_MAX_ERROR,
    since: float | None = None,
) -> bool:
    """Whether :meth:`kcl.controller.UvmsController.telemetry` reports the
    current action converged: not stopped, transition finished, and
    ``convergence`` (largest equality-task error, None = not yet evaluated)
    <= ``max_error``. With ``action``, the current action must be that one, so
    the previous action's convergence is never mistaken for the new one's.
    With ``since`` (s), the controller must have stepped after that time
    (``telemetry["t"] > since``): errors computed before the action (re)started
    or before its targets changed do not count.
    """
    if action is not None and telemetry.get("action") != action:
        return False
    if since is not None and "t" in telemetry and not telemetry["t"] > since:
        return False
    if telemetry.get("stopped") or telemetry.get("transition_progress", 1.0) < 1.0:
        return False
    worst = telemetry.get("convergence")
    return bool(worst is not None and np.isfinite(worst) and worst <= max_error)


def fresh_detection(ctx: MissionContext, min_confidence: float, max_age_s: float) -> Detection | None:
    """The latest detection if fresh and confident enough, else None."""
    detector = ctx.devices.detector
    det = detector.latest() if detector is not None else None
    if det is None:
        return None
    age = ctx.now() - det.t
    if not np.isfinite(age) or age > max_age_s or not det.confidence >= min_confidence:
        return None
    if not np.all(np.isfinite(np.asarray(det.pose, float))):
        return None
    return det


class PredicateEval:
    """Evaluates one predicate against a context (see the module docstring)."""

    def __init__(self, kind: str, params: Mapping[str, Any]):
        self.kind = kind
        self.params = dict(params)
        self._eval: Callable[[MissionContext], Result] = getattr(self, f"_eval_{kind}")
        #: vehicle poses seen at each evaluation, to place detections at their image time
        self.nav_history = NavHistory()
        self._since: float | None = None
        self._held_since: float | None = None

    @classmethod
    def from_spec(cls, predicate: Any) -> PredicateEval:
        """From a :class:`mission.spec.Predicate`."""
        return cls(predicate.kind, predicate.params)

    def holds(self, ctx: MissionContext, since: float | None = None) -> Result:
        """Evaluate now. ``since`` (s): for ``converged``, only controller steps
        after this time count (the caller's start or last target change)."""
        self._since = since
        ok, detail = self._eval(ctx)
        return bool(ok), detail  # a plain bool: py_trees refuses numpy booleans

    def reset(self) -> None:
        """Forget state kept between evaluations (call when the user node starts)."""
        self._held_since = None
        self.nav_history = NavHistory()

    def describe(self) -> str:
        """Readable text, e.g. ``detected min_confidence=0.6`` or ``attempts below 3``."""
        if self.kind == "blackboard" and self.params.get("op"):
            p = self.params
            return f"{p.get('key')} {p['op'].replace('_', ' ')} {p.get('value')!r}"
        inner = " ".join(f"{k}={v}" for k, v in self.params.items() if v is not None)
        return f"{self.kind} {inner}".strip()

    # ------------------------------------------------------------------ kinds
    def _eval_detected(self, ctx: MissionContext) -> Result:
        nav = ctx.devices.vehicle.navigation()
        self.nav_history.add(nav)
        det = fresh_detection(ctx, self.params.get("min_confidence", 0.5), self.params.get("max_age_s", 1.0))
        if det is None:
            return False, "no fresh detection"
        key = self.params.get("store_as")
        if key:
            ctx.blackboard.set(key, grasp_pose_world(nav, det, self.nav_history))
        return True, f"detected (confidence {det.confidence:.2f}, image time {det.t:.2f} s)"

    def _eval_grasp_detected(self, ctx: MissionContext) -> Result:
        gripper = ctx.devices.gripper
        if gripper is None:
            return False, "no gripper"
        st = gripper.state()
        if st.fault:
            return False, f"gripper fault: {st.fault}"
        above = int(np.sum(np.asarray(st.currents, float) >= self.params["current_a"]))
        if st.motion is GripperMotion.HOLDING and above >= self.params.get("min_groups", 1):
            return True, f"grasp detected: {above} motor groups above {self.params['current_a']} A, holding"
        return False, f"motion {st.motion.value}, {above} groups above {self.params['current_a']} A"

    def _eval_converged(self, ctx: MissionContext) -> Result:
        tel = controller_status(ctx.controller)
        limit = self.params.get("max_error") or DEFAULT_MAX_ERROR
        dwell = self.params.get("for_s") or 0.0
        worst = tel.get("convergence")
        shown = "n/a" if worst is None else f"{worst:.3f}"
        if not telemetry_converged(tel, None, limit, self._since):
            self._held_since = None
            return False, f"not converged (worst error {shown}, limit {limit:g})"
        now = ctx.now()
        if self._held_since is None:
            self._held_since = now
        held = now - self._held_since
        if held < dwell:
            return False, f"converged for {held:.1f} of {dwell:g} s (worst error {shown})"
        return True, f"converged (worst error {shown}, limit {limit:g})"

    def _in_range(self, value: float | None, what: str) -> Result:
        if value is None or not np.isfinite(value):
            return False, f"{what} unknown"
        lo, hi = self.params.get("min"), self.params.get("max")
        ok = (lo is None or value >= lo) and (hi is None or value <= hi)
        return bool(ok), f"{what} {value:.2f}"

    def _eval_depth_m(self, ctx: MissionContext) -> Result:
        return self._in_range(ctx.devices.vehicle.navigation().depth, "depth")

    def _eval_altitude_m(self, ctx: MissionContext) -> Result:
        return self._in_range(ctx.devices.vehicle.navigation().altitude, "altitude")

    def _eval_force_n(self, ctx: MissionContext) -> Result:
        sensor = ctx.devices.wrench_sensor
        w = sensor.wrench() if sensor is not None else None
        return self._in_range(None if w is None else float(np.linalg.norm(w.force)), "force")

    def _eval_blackboard(self, ctx: MissionContext) -> Result:
        key, op, ref = self.params["key"], self.params["op"], self.params["value"]
        if op == "is_set":
            is_set = ctx.blackboard.is_set(key)
            return is_set == ref, f"{key} {'set' if is_set else 'unset'}"
        if not ctx.blackboard.is_set(key):
            return False, f"{key} unset"
        v = ctx.blackboard.get(key)
        ok = {
            "equals": lambda: v == ref,
            "not_equals": lambda: v != ref,
            "below": lambda: v < ref,
            "above": lambda: v > ref,
            "at_most": lambda: v <= ref,
            "at_least": lambda: v >= ref,
        }[op]()
        return bool(ok), f"{key} = {v!r}"
