"""The coordinated vehicle-arm controller (MARIS free-floating controller).

One :class:`UvmsController` per vehicle. It holds the current action, the
targets and a little filter state; the maths is in :mod:`kcl.tasks`,
:mod:`kcl.icat` and :mod:`kcl.model`. Two task-priority solutions run in
parallel, at two rates chosen by the caller (the runtime loop):

* :meth:`UvmsController.vehicle_step` (vehicle rate, ~10 Hz): TPIK 1 over the
  whole hierarchy; on top, the measured-velocity task on the NON-actuated
  vehicle DOFs. Returns the body-velocity reference ``[u v w p q r]`` (vehicle
  frame), non-actuated components zero. Without a velocity measurement in this
  step (``MeasuredState.v is None``: DVL/AHRS velocity lost) the top task uses
  the last commanded velocity, as TPIK 2 does, i.e. zero on the non-actuated
  DOFs: the solver then assumes they do not move, rather than keep the last
  filtered value for as long as the sensor is out (the filter keeps its state
  and resumes when measurements return). ``telemetry()`` says which was used
  (``tpik1_velocity_source`` / ``tpik2_velocity_source``).
* :meth:`UvmsController.arm_step` (arm rate, >= 100 Hz): TPIK 2, whose top task
  pins all six vehicle DOFs to the low-pass filtered MEASURED vehicle velocity
  (compensation on), or to the last commanded one (compensation off or no
  velocity measurement). Returns the joint velocity references (rad/s).

Both are saturated to the vehicle / joint velocity limits, and both apply the
action-transition factor ``a_p`` (MARIS eq. 13) so switching action fades tasks
in and out over the file's ``transition_time``; the hierarchy is never rebuilt.
A switch in the middle of a transition starts each task's fade from its current
``a_p`` (the spec's 0/1 case is the special case), so references stay continuous.

Faults: a non-finite input (joints, pose, velocity, altitude, targets) or a
failed solution gives zero references and ``telemetry()["fault"] = True`` with a
reason, for that step; the next good step runs normally again (the supervisor
decides whether to abort). Shapes that do not match the model raise ValueError
(programming error, not a field fault).

Speed (benchmarks/kcl_cycle.py): the tasks with a compiled row kernel are
evaluated together, one compiled call per state (:class:`kcl.tasks.batch.TaskBatch`,
frame Jacobians read once and shared between tasks; :meth:`kcl.stacking.StackingMixin._run_batch`);
their rows are then written into two preallocated
:class:`kcl.icat_stacked.StackedLevels` (in steady state, when every task of the
action has a kernel, by one compiled copy: :meth:`kcl.stacking.StackingMixin._fill_compiled`;
otherwise task by task in :meth:`kcl.stacking.StackingMixin._fill`) and solved by one
compiled call each (:func:`kcl.icat_stacked.solve_stacked`; TPIK 2 in the steady
plan is stacked, solved and clipped by ONE compiled call, :func:`kcl.cycle.gather_solve`,
and on a fresh state the task kernels run in that same call too,
:func:`kcl.arm_cycle.arm_cycle`, chosen by :meth:`kcl.stacking.StackingMixin._arm_fast`);
the input check and the velocity filter step are compiled too (:func:`kcl.cycle.finite_total`,
:mod:`kcl.filters`), and the kinematics snapshot is set up by one (:mod:`kcl.kin_kernel`);
in the usual arm step all three run inside that one call (:mod:`kcl.controller_arm`), and the
kernels' frames are computed there too (:mod:`kcl.kin_frames`, no Pinocchio call);
task outputs are shared
between the two TPIKs at the same state, and when TPIK 1 has just stacked the
same state and time, TPIK 2's stack is sliced out of it
(:meth:`kcl.stacking.StackingMixin._derive_arm_stack`). The kernels are loaded (or
compiled) at construction, never inside a control cycle.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from kcl.actions import ActionSet
from kcl.activation import increasing_bell
from kcl.controller_arm import FusedArmMixin
from kcl.controller_inputs import InputsMixin
from kcl.controller_report import ReportingMixin
from kcl.controller_types import ControllerConfig, MeasuredState, kernel_ready
from kcl.controller_vehicle import FusedVehicleMixin
from kcl.cycle import finite_total, no_compile
from kcl.filters import FirstOrderLowPass
from kcl.icat import _kernel, warm_up
from kcl.icat_stacked import StackedLevels, solve_stacked
from kcl.model import UvmsModel
from kcl.stacking import UNSOLVED, RowRanges, StackingMixin, derivable
from kcl.tasks import MeasuredVehicleVelocity, Targets, Task, TaskContext, TaskOutput
from kcl.tasks.batch import TaskBatch

__all__ = ["ControllerConfig", "MeasuredState", "UvmsController"]


class UvmsController(InputsMixin, FusedArmMixin, FusedVehicleMixin, StackingMixin, ReportingMixin):
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
        self._l = l
        self._q_shape = (l,)
        self._actuated = np.array(config.actuated_dofs, dtype=bool)
        if self._actuated.shape != (6,):
            raise ValueError("actuated_dofs needs 6 booleans")
        self._all_actuated = bool(self._actuated.all())
        self._actuated_f = self._actuated.astype(float)  # (kcl.vehicle_cycle)
        self._a_top1 = (~self._actuated).astype(float)  # TPIK 1's top task activation (kcl.tasks.measured_velocity)
        vlim = np.asarray(config.vehicle_velocity_limit, dtype=float)
        jlim = (
            model.joint_velocity_limit
            if config.joint_velocity_limit is None
            else np.asarray(config.joint_velocity_limit, dtype=float)
        )
        if vlim.shape != (6,) or jlim.shape != (l,) or np.any(vlim < 0) or np.any(jlim < 0):
            raise ValueError(f"velocity limits need shapes (6,) and ({l},), values >= 0")
        self._jlim = jlim.copy()
        self._vlim = vlim.copy()
        self._jlim_neg = -self._jlim
        self._vlim_neg = -self._vlim
        # TPIK 1: the non-actuated DOFs follow a measurement, never saturated
        self._limits1 = np.concatenate([jlim, np.where(self._actuated, vlim, np.inf)])
        self._lam = actions.lam if config.lam is None else config.lam
        self._threshold = actions.threshold if config.threshold is None else config.threshold
        self._lam_f, self._threshold_f, self._eta_f = float(self._lam), float(self._threshold), float(config.eta)
        self._filter = FirstOrderLowPass(config.filter_cutoff_rad_s, 6)
        self._top1 = MeasuredVehicleVelocity("measured_velocity_nonactuated", model)
        self._task_order = [t.name for lv in actions.levels for t in lv.tasks]
        self._action: str | None = None
        self._prev_action: str | None = None
        self._t_switch = 0.0
        self._ap_from: dict[str, float] = {n: 0.0 for n in self._task_order}
        self._ap_to: dict[str, float] = {n: 0.0 for n in self._task_order}
        self._stopped = True
        self._targets = Targets()
        self._targets_finite = True
        self._v_cmd = np.zeros(6)
        self._qdot_cmd = np.zeros(l)
        # task name -> (t, activation with a_p, TaskOutput): a plain tuple per
        # task and cycle; _TaskRecord views are built only when reporting
        self._records: dict[str, tuple[float, np.ndarray, TaskOutput]] = {}
        self._fault = False
        self._fault_reason = ""
        self._fault_count = 0
        self._t_last = 0.0
        self._v_tpik2 = np.zeros(6)
        self._v_tpik1: np.ndarray | None = None  # the velocity TPIK 1's top task was last given
        self._v_source1 = self._v_source2 = "commanded"  # what the top (measured-velocity) task of each TPIK used
        self._targets_version = 0
        self._cache_key: tuple | None = None
        self._q_in = self._eta_in = np.zeros(0)  # the last checked measurement (kcl.controller_inputs)
        self._cache_kin = None
        self._cache_out: dict[str, TaskOutput] = {}
        self._full_plan = [self._plan_entry(lv, lv.tasks) for lv in actions.levels]
        self._plan: list[tuple[tuple[Task, ...], float, float, str]] = []
        # preallocated flat stacks, refilled every cycle (kcl.icat_stacked.StackedLevels)
        all_tasks = [tk for lv in actions.levels for tk in lv.tasks]
        n_levels = len(actions.levels) + 1
        self._stack1 = StackedLevels(6 + sum(tk.dim() for tk in all_tasks), model.n, n_levels)
        self._stack2 = StackedLevels(sum(tk.dim() for tk in all_tasks if tk.USES_ARM), l, n_levels)
        # TPIK 2's rows inside TPIK 1's stack (see _derive_arm_stack)
        self._arm_rows = RowRanges()
        self._one_block = np.zeros((1, 2), dtype=np.int64)  # [0, rows): _fill's arm-only copy (kcl.stacking)
        self._arm_levels: list[tuple[int, float, float, str]] = []
        self._derived_key: tuple | None = None
        self._full_derivable = derivable(all_tasks)
        self._plan_derivable = self._full_derivable
        # the tasks with a compiled row kernel, evaluated in one call per cycle
        self._batch = TaskBatch(all_tasks, model.n)
        # the batch's frames computed in the arm step's compiled call (kcl.kin_frames; None: Pinocchio)
        self._chain = model.chain(self._batch.frame_names)
        self._no_chain = (np.zeros(2, dtype=np.int64), np.zeros(0))
        self._wRv = np.empty((3, 3))  # scratch of the fused arm step (kcl.controller_arm)
        self._qff = np.empty(7 + l)
        # arm_only -> (selection, chosen, frames, layout) of the steady plan on a
        # fresh state; layout: see _steady_layout
        self._steady_batch: dict[bool, tuple] = {}
        self._level_memos: dict[bool, tuple] = {}  # kcl.stacking: level layouts to restore
        self._no_velocity = np.zeros(6)
        # compile / load the kernels now, never inside a control cycle; without the
        # compiled solver (numpy path) TPIK 2 is not solved by kcl.cycle
        self._fused = warm_up() and _kernel() is not None
        finite_total(np.zeros(l), np.zeros(6), np.zeros(6), 0.0, 0.0)
        no_compile(finite_total)  # loaded: other argument kinds take the numpy path, never a compile
        self._batch.warm_up(model.kinematics(model.neutral(), np.zeros(6)))
        self._warm_up_gather()

    # ------------------------------------------------------------------ actions

    @property
    def current_action(self) -> str | None:
        return self._action

    @property
    def previous_action(self) -> str | None:
        return self._prev_action

    def action_tasks(self, name: str | None = None) -> tuple[str, ...]:
        """Task names of ``name`` (default: the current action), highest priority first."""
        name = name if name is not None else self._action
        return () if name is None else self.actions.tasks_of(name)

    def _ap(self, task: str, t: float) -> float:
        """Action-transition factor of ``task`` at time ``t`` (s)."""
        start, end = self._ap_from[task], self._ap_to[task]
        if start == end:
            return end
        T = self.actions.transition_time
        if T <= 0.0:
            return end
        return start + (end - start) * float(increasing_bell(t - self._t_switch, 0.0, T))

    def transition_progress(self, t: float) -> float:
        """0 at an action switch, 1 once the transition time has passed."""
        T = self.actions.transition_time
        if T <= 0.0:
            return 1.0
        return float(min(1.0, max(0.0, (t - self._t_switch) / T)))

    def set_action(self, name: str, t: float) -> None:
        """Make ``name`` the current action at time ``t`` (s): its tasks fade in,
        the others fade out (never a rebuild). Same action again: no change
        (except that it ends a :meth:`stop`, fading the action back in)."""
        wanted = set(self.actions.tasks_of(name))  # KeyError on unknown names
        if name == self._action and not self._stopped:
            return
        for task in self._task_order:
            self._ap_from[task] = 0.0 if self._stopped else self._ap(task, t)
            self._ap_to[task] = 1.0 if task in wanted else 0.0
        if name != self._action:
            self._prev_action = self._action
        # once the transition is over only the action's own tasks run
        plan = [(lv, tuple(tk for tk in lv.tasks if tk.name in wanted)) for lv in self.actions.levels]
        self._plan = [self._plan_entry(lv, tasks) for lv, tasks in plan if tasks]
        self._steady_batch.clear()
        self._plan_derivable = derivable([tk for _lv, tasks in plan for tk in tasks])
        self._derived_key = None
        self._action = name
        self._t_switch = float(t)
        self._stopped = False

    def stop(self, t: float) -> None:
        """Zero references from now until the next :meth:`set_action`."""
        self._stopped = True
        self._derived_key = None
        self._v_cmd = np.zeros(6)
        self._qdot_cmd = np.zeros(self._l)
        self._t_last = float(t)

    @property
    def stopped(self) -> bool:
        return self._stopped

    # ------------------------------------------------------------------ targets

    def set_targets(
        self,
        *,
        tool_goal: np.ndarray | None = None,
        vehicle_goal: np.ndarray | None = None,
        camera_target: np.ndarray | None = None,
    ) -> None:
        """Update targets; arguments left at None keep their previous value.

        tool_goal: (4, 4) world pose (NED) the tool frame must reach (grasp frame).
        vehicle_goal: (4,) ``[x, y, z, yaw]`` world NED (waypoint / station).
        camera_target: (3,) world point the stereo camera keeps in view (None:
        the tool goal's origin). Non-finite values are accepted here and turn into
        a fault (zero references) at the next step. See :meth:`clear_targets`.
        """
        cur = self._targets
        self._targets_version += 1
        self._targets = tg = Targets(
            tool_goal=_as_array(tool_goal, (4, 4), "tool_goal") if tool_goal is not None else cur.tool_goal,
            vehicle_goal=_as_array(vehicle_goal, (4,), "vehicle_goal")
            if vehicle_goal is not None
            else cur.vehicle_goal,
            camera_target=_as_array(camera_target, (3,), "camera_target")
            if camera_target is not None
            else cur.camera_target,
        )
        self._targets_finite = all(
            arr is None or bool(np.isfinite(arr).all()) for arr in (tg.tool_goal, tg.vehicle_goal, tg.camera_target)
        )

    def clear_targets(self) -> None:
        """Forget every target (their tasks become idle)."""
        self._targets_version += 1
        self._targets = Targets()
        self._targets_finite = True

    @property
    def targets(self) -> Targets:
        return self._targets

    # ------------------------------------------------------------------ steps

    def vehicle_step(self, meas: MeasuredState, t: float) -> np.ndarray:
        """TPIK 1 at time ``t`` (s): body velocity reference (6,), vehicle frame;
        non-actuated DOFs zero. The usual step runs in one compiled call
        (:mod:`kcl.controller_vehicle`)."""
        meas = kernel_ready(meas)
        v = self._vehicle_fused(meas, t)
        if v is not UNSOLVED:
            return v
        return self._vehicle_step(meas, t, self._check(meas))

    def _vehicle_step(self, meas: MeasuredState, t: float, reason: str) -> np.ndarray:
        self._t_last = float(t)
        self._derived_key = None
        if self._stopped or reason:
            self._v_cmd = np.zeros(6)
            if reason:
                self._fail(reason)
            return np.zeros(6)
        if meas.v is not None:  # the filtered measurement (the raw one before the first arm step)
            v_top = self._filter.value
            if v_top is None:
                v_top = np.asarray(meas.v, dtype=float)
            self._v_source1 = "measured"
        else:  # no measurement: never a stale filtered value (see the module docstring)
            v_top = self._v_cmd
            self._v_source1 = "commanded"
        self._v_tpik1 = np.array(v_top, dtype=float)
        ctx = self._context(meas, v_top)
        stack = self._stack1
        stack.clear()
        if not self._all_actuated:
            top = self._top1.evaluate(ctx)
            stack.J[:6] = top.J
            stack.a[:6] = top.a
            stack.xdot[:6] = top.xdot
            stack.close_level(6, self._lam, self._threshold, self._top1.name)
        self._fill(stack, ctx, t, arm_only=False)
        if self._plan_derivable if t - self._t_switch >= self.actions.transition_time else self._full_derivable:
            self._derived_key = (self._cache_key, t)
        ydot = self._run_tpik(stack, self._limits1)
        if ydot is None:
            self._v_cmd = np.zeros(6)
            return np.zeros(6)
        v = ydot[self._l :]
        if not self._all_actuated:
            v[~self._actuated] = 0.0
        np.minimum(v, self._vlim, out=v)  # clip (np.clip costs more at this size)
        np.maximum(v, self._vlim_neg, out=v)
        self._v_cmd = v
        self._fault = False
        return v.copy()

    def arm_step(self, meas: MeasuredState, t: float) -> np.ndarray:
        """TPIK 2 at time ``t`` (s): joint velocity references (l,), rad/s.
        The usual step runs in one compiled call (:mod:`kcl.controller_arm`)."""
        return self._arm_ready(kernel_ready(meas), t)

    def _arm_ready(self, meas: MeasuredState, t: float) -> np.ndarray:
        """:meth:`arm_step` of a measurement already through :func:`kernel_ready`."""
        qdot = self._arm_fused(meas, t)
        if qdot is not UNSOLVED:
            return qdot
        return self._arm_step(meas, t, self._check(meas))

    def _arm_step(self, meas: MeasuredState, t: float, reason: str) -> np.ndarray:
        self._t_last = float(t)
        if reason:
            self._qdot_cmd = np.zeros(self._l)
            self._fail(reason)
            return np.zeros(self._l)
        if meas.v is not None:
            self._filter.feed(meas.v, meas.t)
        if self._stopped:
            self._qdot_cmd = np.zeros(self._l)
            return np.zeros(self._l)
        v_filt = self._filter.value
        measured = self.config.compensation and v_filt is not None and meas.v is not None
        v_top = v_filt if measured else self._v_cmd
        self._v_tpik2 = v_top
        self._v_source2 = "measured" if measured else "commanded"
        kin = self._kinematics(meas)
        stack = self._stack2
        solved = UNSOLVED
        if self._derived_key is not None and self._derived_key == (self._cache_key, t):
            self._derive_arm_stack(v_top)  # TPIK 1 just stacked this state: reuse its rows
        else:
            stack.clear()
            solved = self._arm_fast(stack, kin, meas.altitude, t, v_top)  # the usual arm step: one compiled call
            if solved is UNSOLVED:
                ctx = TaskContext(kin, self._targets, meas.altitude, v_top, self._actuated)
                solved = self._fill(stack, ctx, t, arm_only=True, v_top=v_top, limits=self._jlim)
        if solved is UNSOLVED:
            qdot = self._run_tpik(stack, self._jlim)
            if qdot is not None:
                np.minimum(qdot, self._jlim, out=qdot)
                np.maximum(qdot, self._jlim_neg, out=qdot)
        else:  # stacked, solved and clipped in one compiled call (kcl.cycle)
            qdot = solved
        return self._arm_result(qdot)

    def _arm_result(self, qdot: np.ndarray | None) -> np.ndarray:
        """Keep TPIK 2's clipped joint velocities (rad/s; None after a fault: zeros) as
        the last arm command and return a copy of them."""
        if qdot is None:
            self._qdot_cmd = np.zeros(self._l)
            return np.zeros(self._l)
        self._qdot_cmd = qdot
        self._fault = False
        return qdot.copy()

    def step(self, meas: MeasuredState, t: float) -> tuple[np.ndarray, np.ndarray]:
        """Both solutions at one instant: ``(vehicle_step(...), arm_step(...))``, what
        the runtime's vehicle tick runs. Task values are computed once and shared:
        the usual step is two compiled calls (:mod:`kcl.controller_vehicle`, then
        :mod:`kcl.controller_arm` on the rows still in the batch); when the vehicle
        step cannot take its compiled call, the inputs are checked once and TPIK 2's
        stack is sliced out of TPIK 1's."""
        meas = kernel_ready(meas)
        v = self._vehicle_fused(meas, t)
        if v is UNSOLVED:
            reason = self._check(meas)
            return self._vehicle_step(meas, t, reason), self._arm_step(meas, t, reason)
        return v, self._arm_ready(meas, t)

    # ------------------------------------------------------------------ internals

    def _evaluate(self, task: Task, ctx: TaskContext) -> TaskOutput:
        """Task output, shared between TPIK 1 and TPIK 2 at the same state
        (velocity tasks depend on the fed velocity and are always re-evaluated)."""
        if task.KIND == "velocity":
            return task.evaluate_for_solver(ctx)
        out = self._cache_out.get(task.name)
        if out is None:
            out = self._cache_out[task.name] = task.evaluate_for_solver(ctx)
        return out

    def _plan_entry(self, lv: Any, tasks: tuple[Task, ...]) -> tuple[tuple[Task, ...], float, float, str]:
        """(tasks, lam, threshold, name) of one level; None in the file = the default."""
        lam = self._lam if lv.lam is None else lv.lam
        threshold = self._threshold if lv.threshold is None else lv.threshold
        return tasks, float(lam), float(threshold), lv.name

    def _run_tpik(self, stack: StackedLevels, limits: np.ndarray) -> np.ndarray | None:
        """Solve the filled stack (minimum-velocity level appended); None (and a
        fault) on failure."""
        if stack.count == 0:  # nothing active: the minimum-velocity solution is zero
            return np.zeros(stack.n)
        try:
            ydot = solve_stacked(stack, lam=self._lam, threshold=self._threshold, eta=self.config.eta, limits=limits)
        except ValueError as exc:  # non-finite task data: refuse to move
            self._fail(f"solver refused the task data: {exc}")
            return None
        values = ydot.tolist()  # the sum is finite iff every entry is, unless it overflows: then one by one
        if not -math.inf < sum(values) < math.inf and not all(map(math.isfinite, values)):
            self._fail("solver returned a non-finite velocity")
            return None
        return ydot

    def _fail(self, reason: str) -> None:
        self._fault = True
        self._fault_reason = reason
        self._fault_count += 1


def _as_array(value: Any, shape: tuple[int, ...], name: str) -> np.ndarray:
    arr = np.array(value, dtype=float)
    if arr.shape != shape:
        raise ValueError(f"{name} must have shape {shape}, got {arr.shape}")
    return arr
