"""States of the ``grasp`` action for the KCL benchmarks (benchmarks/kcl_cycle.py).

Two workloads, each a list of :class:`StateSet` entries (measurements plus the
targets they go with):

* :func:`typical_states`: a closed-loop grasp from a nearby start (perfect
  tracking, 100 Hz). Most of its states activate only the equality tasks and
  the horizontal attitude: the usual cycle of a grasp.
* :func:`worst_states`: states where EVERY task of the grasp action is active
  in both TPIKs (a > 0 on every row): all seven joints inside their limit
  bands, manipulability below ``mu_min + width``, the elbow close to the stereo
  camera's line of sight to the camera target, that target off the optical
  axis, roll and pitch past ``max_angle - width``, altitude below
  ``min_altitude + width``, the vehicle inside the geofence's band on every
  axis (when the action holds the geofence task). Found by a seeded search over the joint-limit bands
  (then small perturbations of the best state), each state checked by running
  the controller on it: no state is taken on trust.

:func:`stack_shape` reports the levels and rows each TPIK solved at the last
step (rows with a > 0: the kernel drops rows whose activation is zero).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from kcl.actions import ActionSet
from kcl.controller import ControllerConfig, MeasuredState, UvmsController
from kcl.model import UvmsModel
from kcl.rotations import integrate_pose

FLOOR_Z = 11.3  # m, world NED depth of the flat bottom in the typical states


@dataclass
class StateSet:
    """Measurements of one workload and the targets they are solved with."""

    name: str
    states: list[MeasuredState]
    tool_goal: np.ndarray  # (4, 4) world
    camera_target: np.ndarray | None  # (3,) world; None = the tool goal's origin
    geofence: np.ndarray | None = None  # (3, 2) world NED box; None = no fence (the task idles)


@dataclass(frozen=True)
class StackShape:
    """Levels and rows (a > 0) each TPIK solved, without the final
    minimum-velocity level (13 rows in TPIK 1, l rows in TPIK 2)."""

    levels1: int
    rows1: int
    levels2: int
    rows2: int

    def text(self) -> str:
        return f"TPIK 1 {self.levels1} levels / {self.rows1} rows, TPIK 2 {self.levels2} levels / {self.rows2} rows"


def make_controller(model: UvmsModel, actions: ActionSet, workload: StateSet) -> UvmsController:
    """A controller in the steady ``grasp`` action (transition over) with the workload's targets."""
    ctrl = UvmsController(model, actions, ControllerConfig())
    ctrl.set_targets(tool_goal=workload.tool_goal, camera_target=workload.camera_target, geofence=workload.geofence)
    ctrl.set_action("grasp", -10.0)
    return ctrl


def stack_shape(ctrl: UvmsController) -> StackShape:
    """Levels and active rows of both TPIKs as filled by the last ``step``."""
    shapes = []
    for problem in (ctrl.tpik1, ctrl.tpik2):
        rows_used = int(problem.stack.offsets[problem.levels])
        rows = int(np.count_nonzero(problem.stack.a[:rows_used] > 0.0))
        shapes += [problem.levels, rows]
    return StackShape(*shapes)


def full_shape(model: UvmsModel, actions: ActionSet) -> StackShape:
    """The shape with every task of ``grasp`` active: TPIK 1 all of them, TPIK 2
    those that move the arm (the others cannot act once the vehicle is pinned)."""
    tasks = [actions.tasks[n] for n in actions.tasks_of("grasp")]
    arm = [t for t in tasks if t.USES_ARM]
    return StackShape(len(tasks), sum(t.dim() for t in tasks), len(arm), sum(t.dim() for t in arm))


def shapes_of(model: UvmsModel, actions: ActionSet, workload: StateSet) -> list[StackShape]:
    """The stack shape of every state of ``workload`` (one controller step each)."""
    ctrl = make_controller(model, actions, workload)
    out = []
    for k, s in enumerate(workload.states):
        t = 100.0 + 0.01 * k
        ctrl.step(MeasuredState(s.q, s.eta, s.v, t, s.altitude), t)
        out.append(stack_shape(ctrl))
    return out


def typical_states(model: UvmsModel, actions: ActionSet, n_states: int) -> StateSet:
    """States of a closed-loop grasp (perfect tracking, arm at 100 Hz, vehicle at 10 Hz)."""
    eta = np.array([0.0, 0.0, 10.0, 0.0, 0.0, 0.4])
    ready = np.array(actions.postures["grasp_ready"], dtype=float)
    q = ready + 0.25
    goal = model.frame_pose_world(ready - 0.1, eta + np.r_[0.2, -0.1, 0.1, 0, 0, 0.2], "tool")
    ctrl = UvmsController(model, actions, ControllerConfig())
    ctrl.set_targets(tool_goal=goal)
    ctrl.set_action("grasp", 0.0)
    states = []
    v = np.zeros(6)
    for k in range(n_states):
        t = 0.01 * k
        meas = MeasuredState(q.copy(), eta.copy(), v.copy(), t, FLOOR_Z - eta[2])
        states.append(meas)
        if k % 10 == 0:
            v = ctrl.vehicle_step(meas, t)
        q = q + 0.01 * ctrl.arm_step(meas, t)
        eta = integrate_pose(eta, v, 0.01)
    return StateSet("typical", states, goal, None)


def _camera_target_near_elbow(model: UvmsModel, q: np.ndarray, eta: np.ndarray, distance: float) -> np.ndarray:
    """A world point whose line of sight from the stereo camera passes ``distance``
    (m) from the elbow, beyond it (the elbow partly hides the target)."""
    kin = model.kinematics(q, eta)
    cam = kin.pose_world("stereo_camera")[:3, 3]
    s = kin.position_world("elbow") - cam
    ns = float(np.linalg.norm(s))
    u = s / ns
    side = np.cross(u, kin.pose_world("stereo_camera")[:3, 2])  # any direction normal to u will do
    side /= np.linalg.norm(side)
    delta = np.arcsin(min(0.99, distance / ns))
    direction = np.cos(delta) * u + np.sin(delta) * np.cross(side, u)
    return cam + 2.0 * ns * direction


def worst_states(model: UvmsModel, actions: ActionSet, n_states: int, seed: int = 7, tries: int = 4000) -> StateSet:
    """``n_states`` states that activate every row of every grasp task in both TPIKs."""
    tasks = actions.tasks
    jl = tasks["joint_limits"].params
    lo_band = model.joint_lower + jl["margin"]
    hi_band = model.joint_upper - jl["margin"]
    width = jl["width"]
    mu_top = tasks["manipulability"].params["mu_min"] + tasks["manipulability"].params["width"]
    alt = tasks["altitude"].params
    att = tasks["horizontal_attitude"].params
    occ = tasks["elbow_occlusion"].params
    fence = tasks["geofence"].params if "geofence" in actions.tasks_of("grasp") else None
    rng = np.random.default_rng(seed)
    want = full_shape(model, actions)
    # 1) joint configurations inside the limit bands with low manipulability
    best = None
    eta0 = np.array([0.0, 0.0, 10.0, 0.0, 0.0, 0.3])
    for _ in range(tries):
        upper = rng.random(model.n_joints) < 0.5
        depth = rng.uniform(0.2, 0.8, model.n_joints) * width
        q = np.where(upper, hi_band - depth, lo_band + depth)
        mu, _grad = model.kinematics(q, eta0).manipulability("tool")
        if not 0.3 * mu_top < mu < 0.8 * mu_top:
            continue
        roll, pitch = rng.choice([-1.0, 1.0], 2) * (att["max_angle"] - 0.5 * att["width"])
        eta = np.array([0.0, 0.0, 10.0, roll, pitch, 0.3])
        target = _camera_target_near_elbow(model, q, eta, occ["min_distance"] + 0.5 * occ["width"])
        kin = model.kinematics(q, eta)
        tool = kin.pose_world("tool").copy()
        goal = tool.copy()
        goal[:3, 3] += (0.05, -0.04, 0.03)
        altitude = alt["min_altitude"] + 0.5 * alt["width"]
        geofence = None
        if fence is not None:  # the lower faces half a band below the vehicle, the upper ones far
            lower = eta[:3] - fence["margin"] - 0.5 * fence["width"]
            geofence = np.column_stack([lower, lower + 100.0])
        candidate = StateSet("worst", [MeasuredState(q, eta, np.zeros(6), 0.0, altitude)], goal, target, geofence)
        if shapes_of(model, actions, candidate)[0] == want:
            best = candidate
            break
    if best is None:
        raise RuntimeError("no state activating every grasp task was found: the model or actions changed?")
    # 2) small perturbations of it, each checked
    base = best.states[0]
    states: list[MeasuredState] = []
    while len(states) < n_states:
        batch = []
        for _ in range(n_states):
            q = base.q + rng.uniform(-0.01, 0.01, model.n_joints)
            eta = base.eta + np.r_[rng.uniform(-0.02, 0.02, 3), rng.uniform(-0.002, 0.002, 3)]
            v = rng.normal(0.0, 0.02, 6)
            batch.append(MeasuredState(q, eta, v, 0.0, base.altitude + rng.uniform(-0.02, 0.02)))
        trial = StateSet("worst", batch, best.tool_goal, best.camera_target, best.geofence)
        states += [s for s, shape in zip(batch, shapes_of(model, actions, trial)) if shape == want]
    return StateSet("worst", states[:n_states], best.tool_goal, best.camera_target, best.geofence)
