"""The coordinated vehicle-arm controller (MARIS free-floating controller).

One :class:`UvmsController` per vehicle. Two task-priority solutions run in
parallel, at two rates chosen by the caller (the runtime loop):

* :meth:`UvmsController.vehicle_step` (vehicle rate, ~10 Hz): TPIK 1 over the
  whole hierarchy; on top, the measured-velocity task on the NON-actuated
  vehicle DOFs. Returns the body-velocity reference ``[u v w p q r]`` (vehicle
  frame), non-actuated components zero. Without a velocity measurement in this
  step (``MeasuredState.v is None``: DVL/AHRS velocity lost) the top task uses
  the last commanded velocity, as TPIK 2 does, i.e. zero on the non-actuated
  DOFs: the solver then assumes they do not move, rather than keep the last
  filtered value for as long as the sensor is out (the filter keeps its state
  and resumes when measurements return).
* :meth:`UvmsController.arm_step` (arm rate, >= 100 Hz): TPIK 2, whose top task
  pins all six vehicle DOFs to the low-pass filtered MEASURED vehicle velocity
  (compensation on), or to the last commanded one (compensation off or no
  velocity measurement). Returns the joint velocity references (rad/s).

Both are saturated to the vehicle / joint velocity limits, and both apply the
action-transition factor ``a_p`` (MARIS eq. 13, :class:`kcl.blend.ActionBlend`),
so switching action fades tasks in and out over the file's ``transition_time``;
the hierarchy is never rebuilt.

The controller is a thin stateful shell around pure parts: the action blend, the
velocity filter (:mod:`kcl.filters`), the task batch (:mod:`kcl.tasks.batch`),
the two problems of :mod:`kcl.cycle` (each step is ONE compiled call) and the
reports (:mod:`kcl.telemetry`).

Faults: a non-finite input (joints, pose, velocity, altitude, targets) or a
failed solution gives zero references and ``telemetry()["fault"] = True`` with a
reason, for that step; the next good step runs normally again (the supervisor
decides whether to abort). Shapes that do not match the model raise ValueError
(a programming error, not a field fault).
"""

from __future__ import annotations

import math
from dataclasses import replace
from typing import Any

import numpy as np

from kcl.actions import ActionSet
from kcl.blend import ActionBlend
from kcl.controller_types import ControllerConfig, MeasuredState, kernel_ready
from kcl.cycle import INPUTS_NOT_FINITE, SOLVED, PlanLevel, StackPlan, TpikProblem, tpik_cycle
from kcl.filters import NO_CHANGE, FirstOrderLowPass
from kcl.jit import lock_types
from kcl.model import UvmsModel
from kcl.tasks import Targets
from kcl.tasks.batch import TaskBatch
from kcl.telemetry import ControllerStatus, StepState, TelemetrySnapshot, convergence, limited, status

__all__ = ["ControllerConfig", "MeasuredState", "UvmsController"]

#: name of TPIK 1's top level (the measured-velocity task on the non-actuated DOFs)
TOP_LEVEL_NAME = "measured_velocity_nonactuated"


def hierarchy_plan(
    actions: ActionSet,
    batch: TaskBatch,
    *,
    arm_only: bool,
    actuated: np.ndarray,
    limits: np.ndarray,
    clip: np.ndarray,
    lam: float,
    threshold: float,
    eta: float,
) -> StackPlan:
    """The :class:`kcl.cycle.StackPlan` of one TPIK over the whole hierarchy of
    ``actions`` (TPIK 2, ``arm_only``: the tasks that use the arm); a level's
    regularization defaults to ``lam`` / ``threshold``, those of the top and
    minimum-velocity levels; ``eta`` weighs the (I - Q) term."""
    slots, task_index, level_of, inequality = [], [], [], []
    position = 0
    for li, level in enumerate(actions.levels):
        for task in level.tasks:
            if not (arm_only and not task.USES_ARM):
                slots.append(batch.index[task.name])
                task_index.append(position)
                level_of.append(li)
                inequality.append(task.KIND == "inequality")
            position += 1
    levels = tuple(
        PlanLevel(
            lv.name,
            float(lam if lv.lam is None else lv.lam),
            float(threshold if lv.threshold is None else lv.threshold),
        )
        for lv in actions.levels
    )
    top = not arm_only and not bool(actuated.all())
    return StackPlan(
        slots=np.array(slots, dtype=np.int64),
        task_index=np.array(task_index, dtype=np.int64),
        level_of=np.array(level_of, dtype=np.int64),
        inequality=np.array(inequality, dtype=bool),
        levels=levels,
        arm_only=arm_only,
        top=top,
        a_top=(~actuated).astype(float),
        actuated=np.ones(clip.shape[0]) if arm_only else actuated.astype(float),
        limits=np.ascontiguousarray(limits, dtype=float),
        clip=np.ascontiguousarray(clip, dtype=float),
        lam=float(lam),
        threshold=float(threshold),
        eta=float(eta),
    )


class UvmsController:
    """Coordinated controller: ``set_action`` / ``set_targets`` then, each cycle,
    ``vehicle_step`` and ``arm_step`` with the latest :class:`MeasuredState`."""

    def __init__(self, model: UvmsModel, actions: ActionSet, config: ControllerConfig | None = None):
        self.model = model
        self.actions = actions
        self.config = config = config or ControllerConfig()
        l = model.n_joints
        am = actions.model
        if am is not model and (am.urdf_path != model.urdf_path or am.frames != model.frames):
            raise ValueError(
                f"the actions were built for {am.urdf_path} but the controller model is {model.urdf_path}: "
                "load them with load_actions(path, model)"
            )
        actuated = np.array(config.actuated_dofs, dtype=bool)
        if actuated.shape != (6,):
            raise ValueError("actuated_dofs needs 6 booleans")
        vlim = np.asarray(config.vehicle_velocity_limit, dtype=float)
        jlim = (
            model.joint_velocity_limit
            if config.joint_velocity_limit is None
            else np.asarray(config.joint_velocity_limit, dtype=float)
        )
        if vlim.shape != (6,) or jlim.shape != (l,) or np.any(vlim < 0) or np.any(jlim < 0):
            raise ValueError(f"velocity limits need shapes (6,) and ({l},), values >= 0")
        self._l = l
        self.blend = ActionBlend(actions)
        self.filter = FirstOrderLowPass(config.filter_cutoff_rad_s, 6)
        self.batch = TaskBatch([t for lv in actions.levels for t in lv.tasks], model.n)
        lam = actions.lam if config.lam is None else config.lam
        threshold = actions.threshold if config.threshold is None else config.threshold
        chain = model.chain(self.batch.frame_names)
        # TPIK 1 saturates the actuated vehicle DOFs only: the others follow a measurement
        limits1 = np.concatenate([jlim, np.where(actuated, vlim, np.inf)])
        regularization = {"lam": lam, "threshold": threshold, "eta": config.eta}
        plan1 = hierarchy_plan(
            actions, self.batch, arm_only=False, actuated=actuated, limits=limits1, clip=vlim, **regularization
        )
        plan2 = hierarchy_plan(
            actions, self.batch, arm_only=True, actuated=actuated, limits=jlim, clip=jlim, **regularization
        )
        self.tpik1, self.tpik2 = (
            TpikProblem(plan, self.batch, chain, l=l, top_name=TOP_LEVEL_NAME) for plan in (plan1, plan2)
        )
        self.state = StepState(v_cmd=np.zeros(6), qdot_cmd=np.zeros(l))
        self._targets = Targets()
        self._targets_version = 0
        self._targets_finite = True
        self._state_key: tuple[bytes, bytes, float | None, int] | None = None
        self._state_id = 0
        self._no_velocity = np.zeros(6)
        self._factors_from: np.ndarray | None = None
        self._warm_up()

    def _warm_up(self) -> None:
        """Load (on a machine's first run: compile) the compiled cycle now, never
        inside a control cycle, then forget what the warm-up step left."""
        q, eta = self.model.neutral(), np.zeros(6)
        self.blend.set_action(next(iter(self.actions.actions)), 0.0)
        self.set_targets(tool_goal=np.eye(4), vehicle_goal=np.zeros(4))
        self.step(MeasuredState(q, eta, np.zeros(6), 0.0, 1.0), 0.0)
        lock_types(tpik_cycle)
        self.blend = ActionBlend(self.actions)
        self.filter.reset()
        self.batch.forget()
        self.state = StepState(v_cmd=np.zeros(6), qdot_cmd=np.zeros(self._l))
        self.clear_targets(geofence=True)
        self._state_key = None
        self._factors_from = None

    # ------------------------------------------------------------------ actions

    @property
    def current_action(self) -> str | None:
        return self.blend.action

    @property
    def previous_action(self) -> str | None:
        return self.blend.previous_action

    @property
    def stopped(self) -> bool:
        return self.blend.stopped

    def action_tasks(self, name: str | None = None) -> tuple[str, ...]:
        """Task names of ``name`` (default: the current action), highest priority first."""
        name = name if name is not None else self.blend.action
        return () if name is None else self.actions.tasks_of(name)

    def set_action(self, name: str, t: float) -> None:
        """Make ``name`` the current action at time ``t`` (s): its tasks fade in,
        the others fade out (never a rebuild). Same action again: no change
        (except that it ends a :meth:`stop`, fading the action back in)."""
        self.blend.set_action(name, t)

    def transition_progress(self, t: float) -> float:
        """0 at an action switch, 1 once the transition time has passed."""
        return self.blend.progress(t)

    def stop(self, t: float) -> None:
        """Zero references from now until the next :meth:`set_action`."""
        self.blend.stop()
        self.state.v_cmd = np.zeros(6)
        self.state.qdot_cmd = np.zeros(self._l)
        self.state.t = float(t)

    # ------------------------------------------------------------------ targets

    def set_targets(
        self,
        *,
        tool_goal: np.ndarray | None = None,
        vehicle_goal: np.ndarray | None = None,
        camera_target: np.ndarray | None = None,
        tool_velocity: np.ndarray | None = None,
        vehicle_velocity: np.ndarray | None = None,
        geofence: np.ndarray | None = None,
    ) -> None:
        """Update targets; arguments left at None keep their previous value.

        tool_goal: (4, 4) world pose (NED) the tool frame must reach (grasp frame).
        vehicle_goal: (4,) ``[x, y, z, yaw]`` world NED (waypoint / station).
        camera_target: (3,) world point the stereo camera keeps in view (None:
        the tool goal's origin). tool_velocity: (6,) commanded tool twist (m/s,
        rad/s; its frame is the ``tool_velocity`` task's). vehicle_velocity: (6,)
        commanded body velocity (m/s, rad/s, vehicle frame). geofence: (3, 2) world
        NED box ``[[n0, n1], [e0, e1], [d0, d1]]`` (m). Non-finite values are
        accepted here and turn into a fault (zero references) at the next step.
        See :meth:`clear_targets`.
        """
        given = {
            "tool_goal": tool_goal,
            "vehicle_goal": vehicle_goal,
            "camera_target": camera_target,
            "tool_velocity": tool_velocity,
            "vehicle_velocity": vehicle_velocity,
            "geofence": geofence,
        }
        changed = {name: _as_array(v, TARGET_SHAPES[name], name) for name, v in given.items() if v is not None}
        self._use_targets(replace(self._targets, **changed))

    def clear_targets(self, *, geofence: bool = False) -> None:
        """Forget the actions' targets (their tasks become idle). The geofence, the
        mission's envelope rather than an action's target, stays unless ``geofence``."""
        self._use_targets(Targets(geofence=None if geofence else self._targets.geofence))

    def _use_targets(self, targets: Targets) -> None:
        self._targets = targets
        self._targets_version += 1
        self._targets_finite = all(v is None or bool(np.isfinite(v).all()) for v in vars(targets).values())
        self.batch.set_targets(targets)

    @property
    def targets(self) -> Targets:
        return self._targets

    # ------------------------------------------------------------------ steps

    def vehicle_step(self, meas: MeasuredState, t: float) -> np.ndarray:
        """TPIK 1 at time ``t`` (s): body velocity reference (6,), vehicle frame;
        non-actuated DOFs zero."""
        meas = self._checked(meas)
        state = self.state
        state.t = float(t)
        if not self._targets_finite:
            return self._vehicle_fault(self._input_fault_reason(meas))
        v = meas.v
        if v is not None:  # the filtered measurement (the raw one before the first arm step)
            v_top = self.filter.y if self.filter.t is not None else v
            source = "measured"
        else:  # no measurement: never a stale filtered value (see the module docstring)
            v_top = state.v_cmd
            source = "commanded"
        work = not self.blend.stopped
        problem = self.tpik1
        code = self._run(problem, meas, v_top, NO_CHANGE, 0.0, t, work)
        if code == INPUTS_NOT_FINITE:
            return self._vehicle_fault(self._input_fault_reason(meas))
        if not work:
            state.v_cmd = np.zeros(6)
            return np.zeros(6)
        state.source1 = source
        state.v_tpik1 = np.array(v_top, dtype=float)
        if code != SOLVED:
            return self._vehicle_fault(problem.fault_reason(code))
        out = problem.out.copy()
        state.v_cmd = out
        state.fault = False
        return out.copy()

    def arm_step(self, meas: MeasuredState, t: float) -> np.ndarray:
        """TPIK 2 at time ``t`` (s): joint velocity references (l,), rad/s."""
        meas = self._checked(meas)
        state = self.state
        state.t = float(t)
        if not self._targets_finite:
            return self._arm_fault(self._input_fault_reason(meas))
        v = meas.v
        filt = self.filter
        mode, gain = filt.mode_at(meas.t) if v is not None else (NO_CHANGE, 0.0)
        measured = self.config.compensation and v is not None
        v_top = filt.y if measured else state.v_cmd
        work = not self.blend.stopped
        problem = self.tpik2
        code = self._run(problem, meas, v_top, mode, gain, t, work)
        if code == INPUTS_NOT_FINITE:
            return self._arm_fault(self._input_fault_reason(meas))
        filt.accept(meas.t, mode)
        if not work:
            state.qdot_cmd = np.zeros(self._l)
            return np.zeros(self._l)
        state.v_tpik2 = np.array(v_top, dtype=float)
        state.source2 = "measured" if measured else "commanded"
        if code != SOLVED:
            return self._arm_fault(problem.fault_reason(code))
        out = problem.out.copy()
        state.qdot_cmd = out
        state.fault = False
        return out.copy()

    def step(self, meas: MeasuredState, t: float) -> tuple[np.ndarray, np.ndarray]:
        """Both solutions at one instant: ``(vehicle_step(...), arm_step(...))``, what
        the runtime's vehicle tick runs (the task rows of the state are computed once)."""
        return self.vehicle_step(meas, t), self.arm_step(meas, t)

    # ------------------------------------------------------------------ reports

    def status(self) -> ControllerStatus:
        """The fields of :meth:`telemetry` the mission tree reads every tick."""
        return status(self.state, self.blend, self.batch)

    def limited(self) -> dict[str, dict[str, Any]]:
        """The ``limited`` field of :meth:`telemetry` alone (the tasks of the current action
        the last commands move at < 90 % of their reference, and the active inequality
        tasks above them), for a reader at the tree rate."""
        return limited(self.state, self.blend, self.batch)

    def telemetry(self) -> dict[str, Any]:
        """JSON-able snapshot for the log (see :mod:`kcl.telemetry`)."""
        return self.telemetry_snapshot().message()

    def telemetry_snapshot(self) -> TelemetrySnapshot:
        """What :meth:`telemetry` reports now, its message built later
        (:meth:`TelemetrySnapshot.message`)."""
        return TelemetrySnapshot.take(self.state, self.blend, self.batch, self.filter, self.config.compensation)

    def convergence(self, action: str | None = None) -> float:
        """Largest error norm of the goal tasks of ``action`` (default: the current
        one); ``inf`` while one has not run or has no target."""
        return convergence(self.actions, self.batch, action if action is not None else self.blend.action)

    # ------------------------------------------------------------------ internals

    def _run(
        self, problem: TpikProblem, meas: MeasuredState, v_top: np.ndarray, mode: int, gain: float, t: float, work: bool
    ) -> int:
        """One :meth:`TpikProblem.run` at ``meas``: the state number (task rows are
        reused at the same joints, pose, altitude and targets) and this step's
        action-transition factors."""
        q, eta = meas.q, meas.eta
        if work:
            key = (q.tobytes(), eta.tobytes(), meas.altitude, self._targets_version)
            if key != self._state_key:
                self._state_key = key
                self._state_id += 1
            factors = self.blend.factors_at(t)  # a new array whenever they change
            if factors is not self._factors_from:
                for plan in (self.tpik1.plan, self.tpik2.plan):
                    plan.factors[:] = factors[plan.task_index]
                self._factors_from = factors
        v = meas.v
        return problem.run(
            q,
            eta,
            self._no_velocity if v is None else v,
            v_top,
            self.filter.y,
            t,
            meas.t,
            meas.altitude,
            mode,
            gain,
            self._state_id,
            work,
        )

    def _checked(self, meas: MeasuredState) -> MeasuredState:
        """``meas`` with arrays the compiled cycle takes; ValueError for wrong shapes."""
        meas = kernel_ready(meas)
        if meas.q.shape != (self._l,) or meas.eta.shape != (6,):
            raise ValueError(
                f"MeasuredState: q must be ({self._l},) and eta (6,), got {meas.q.shape} and {meas.eta.shape}"
            )
        if meas.v is not None and meas.v.shape != (6,):
            raise ValueError(f"MeasuredState.v must be (6,), got {meas.v.shape}")
        return meas

    def _input_fault_reason(self, meas: MeasuredState) -> str:
        """Why ``meas`` or the targets cannot be used ('' if they can)."""
        if not (np.isfinite(meas.q).all() and np.isfinite(meas.eta).all()):
            return "non-finite joint positions or vehicle pose"
        if meas.v is not None and not np.isfinite(meas.v).all():
            return "non-finite measured vehicle velocity"
        if meas.altitude is not None and not math.isfinite(meas.altitude):
            return "non-finite altitude"
        if not math.isfinite(meas.t):
            return "non-finite measurement time"
        for name, value in vars(self._targets).items():
            if value is not None and not np.isfinite(value).all():
                return f"non-finite {name}"
        return "inputs out of range (their squares overflow)"

    def _vehicle_fault(self, reason: str) -> np.ndarray:
        self.state.v_cmd = np.zeros(6)
        self.state.fail(reason)
        return np.zeros(6)

    def _arm_fault(self, reason: str) -> np.ndarray:
        self.state.qdot_cmd = np.zeros(self._l)
        self.state.fail(reason)
        return np.zeros(self._l)


#: The shape of each target of :meth:`UvmsController.set_targets`.
TARGET_SHAPES: dict[str, tuple[int, ...]] = {
    "tool_goal": (4, 4),
    "vehicle_goal": (4,),
    "camera_target": (3,),
    "tool_velocity": (6,),
    "vehicle_velocity": (6,),
    "geofence": (3, 2),
}


def _as_array(value: Any, shape: tuple[int, ...], name: str) -> np.ndarray:
    arr = np.array(value, dtype=float)
    if arr.shape != shape:
        raise ValueError(f"{name} must have shape {shape}, got {arr.shape}")
    return arr
