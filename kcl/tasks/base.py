"""Base of every control task of the KCL.

A task turns the current state (a :class:`~kcl.model.Kinematics` snapshot plus
targets and a few measurements, bundled in :class:`TaskContext`) into one
:class:`TaskOutput`: its value ``x``, Jacobian ``J`` (m x n, w.r.t.
``ydot = [qdot; v]``), activation ``a`` in [0, 1]^m (inequality bells only; the
action-transition factor is applied by the controller), reference rate ``xdot``
and an error to log. Tasks are stateless: parameters are fixed at construction
(they come from the actions YAML), everything else arrives in the context.

Each concrete task declares its parameters in ``PARAMS`` (name -> :class:`Param`)
so the actions loader can check a YAML file and report ``file:line:column``.

Most tasks keep their maths in a compiled *row kernel* next to the class
(``ROW_KERNEL``, signature in :mod:`kcl.tasks.jit`); the default
:meth:`Task.evaluate` runs it on the one task, and the controller runs all of
them in one call per cycle (:mod:`kcl.tasks.batch`), so the code the tests check
(finite differences, activations) is the code the controller runs. Tasks without
a kernel (velocity tasks, vehicle pose) override :meth:`Task.evaluate`.
"""

from __future__ import annotations

import math
from abc import ABC, abstractmethod
from dataclasses import dataclass, field
from typing import Any, ClassVar

import numpy as np

from kcl.model import Kinematics, UvmsModel
from kcl.tasks.jit import ENV_SIZE, IDLE_NOTES, pack_env, set_env_velocity


@dataclass(frozen=True)
class Targets:
    """What the tasks aim at (all optional; a task without its target is inactive).

    tool_goal: (4, 4) world pose the tool frame must reach (grasp frame).
    vehicle_goal: (4,) ``[x, y, z, yaw]`` world NED, m and rad.
    camera_target: (3,) world point the stereo camera keeps centred (defaults to
    the tool goal's origin when None).
    """

    tool_goal: np.ndarray | None = None
    vehicle_goal: np.ndarray | None = None
    camera_target: np.ndarray | None = None

    def camera_point(self) -> np.ndarray | None:
        if self.camera_target is not None:
            return self.camera_target
        if self.tool_goal is not None:
            return self.tool_goal[:3, 3]
        return None


@dataclass
class TaskContext:
    """Inputs of one evaluation: kinematics, targets, measurements.

    altitude: measured altitude above the bottom (m), None if unknown.
    v: (6,) vehicle body velocity fed to velocity-type tasks (m/s, rad/s).
    actuated: (6,) bools, which vehicle DOFs the thrusters control.
    """

    kin: Kinematics
    targets: Targets = field(default_factory=Targets)
    altitude: float | None = None
    v: np.ndarray | None = None
    actuated: np.ndarray | None = None


@dataclass
class TaskOutput:
    """One task at one instant. Arrays have m rows; ``note`` says why a task is
    idle (e.g. "no tool_goal"), empty otherwise."""

    x: np.ndarray
    J: np.ndarray
    a: np.ndarray
    xdot: np.ndarray
    error: np.ndarray
    note: str = ""


@dataclass(frozen=True)
class Param:
    """A task parameter as written in the actions YAML.

    kind: ``positive`` / ``nonneg`` (float), ``posture`` (list of l floats or
    nulls), ``frame`` (a frame role or URDF frame name).
    """

    default: Any
    kind: str
    doc: str


def saturate(xdot: np.ndarray, limit: float) -> np.ndarray:
    """Scale ``xdot`` uniformly so that no component exceeds ``limit`` (keeps direction)."""
    if limit == math.inf:
        return xdot
    peak = max(map(abs, xdot.tolist()), default=0.0)
    if peak > limit:
        return xdot * (limit / peak)
    return xdot


class Task(ABC):
    """A control task. Subclasses set ``TYPE``, ``PARAMS``, ``KIND`` and the flags
    ``USES_ARM`` / ``USES_VEHICLE`` (which ydot columns the Jacobian can touch)."""

    TYPE: ClassVar[str] = ""
    KIND: ClassVar[str] = "equality"  # "equality", "inequality" or "velocity"
    PARAMS: ClassVar[dict[str, Param]] = {}
    USES_ARM: ClassVar[bool] = True
    USES_VEHICLE: ClassVar[bool] = True

    def __init__(self, name: str, model: UvmsModel, **params: Any):
        self.name = name
        self.model = model
        #: counts for the controller's convergence measure (actions YAML `goal:`)
        self.is_goal: bool = self.KIND == "equality"
        unknown = set(params) - set(self.PARAMS)
        if unknown:
            raise TypeError(f"{self.TYPE}: unknown parameters {sorted(unknown)}")
        self.params: dict[str, Any] = {k: p.default for k, p in self.PARAMS.items()}
        self.params.update(params)
        self.setup()

    def setup(self) -> None:
        """Precompute what only depends on parameters and the model."""

    @property
    def n(self) -> int:
        return self.model.n

    @property
    def l(self) -> int:  # noqa: E743 - the papers' name for the number of joints
        return self.model.n_joints

    @abstractmethod
    def dim(self) -> int:
        """Number of rows m."""

    #: compiled row kernel (kcl.tasks.jit signature) or None (Python evaluate)
    ROW_KERNEL: ClassVar[Any] = None
    #: its branch number in kcl.tasks.batch (unique per kernel)
    KERNEL_ID: ClassVar[int] = 0

    def kernel_params(self) -> list[float]:
        """The float parameters ``p`` of :attr:`ROW_KERNEL`."""
        return []

    def kernel_frames(self) -> list[str]:
        """The frames (roles or URDF names) :attr:`ROW_KERNEL` reads, in order."""
        return []

    def evaluate(self, ctx: TaskContext) -> TaskOutput:
        """The task at the state in ``ctx``. Default: run :attr:`ROW_KERNEL` on
        this task alone (the very code the controller's batch runs)."""
        if self.ROW_KERNEL is None:
            raise NotImplementedError(f"{type(self).__name__} needs evaluate() or a ROW_KERNEL")
        kin = ctx.kin
        frames = self.kernel_frames()
        P = np.empty((len(frames), 4, 4))
        Jw = np.empty((len(frames), 6, self.n))
        for i, f in enumerate(frames):
            P[i] = kin.pose_world(f)
            Jw[i] = kin.jacobian_world(f)
        env = pack_env(np.empty(ENV_SIZE), ctx.targets, ctx.altitude)
        set_env_velocity(env, ctx.v)
        m = self.dim()
        x, a, xdot, err = np.zeros(m), np.zeros(m), np.zeros(m), np.zeros(m)
        J = np.zeros((m, self.n))
        status = self.ROW_KERNEL(
            np.array(self.kernel_params(), dtype=float),
            np.arange(len(frames), dtype=np.int64),
            P,
            Jw,
            kin.q,
            kin.eta,
            kin.wRv,
            env,
            x,
            J,
            a,
            xdot,
            err,
        )
        if status:
            return self.idle(IDLE_NOTES[status])
        return TaskOutput(x, J, a, xdot, err)

    def evaluate_for_solver(self, ctx: TaskContext) -> TaskOutput:
        """What the controller stacks: :meth:`evaluate`, except that a task may
        leave zero the Jacobian rows whose activation is zero (they never enter
        the solve) to save work. Override only for that."""
        return self.evaluate(ctx)

    def idle(self, note: str) -> TaskOutput:
        """Output of a task that cannot run now (activation zero, reason in ``note``)."""
        m = self.dim()
        z = np.zeros(m)
        return TaskOutput(z, np.zeros((m, self.n)), z.copy(), z.copy(), z.copy(), note)

    def __repr__(self) -> str:
        return f"{type(self).__name__}({self.name!r})"


# common parameters
GAIN = Param(1.0, "positive", "gain gamma of the reactive reference, 1/s")
MAX_RATE = Param(math.inf, "positive", "saturation of the reference rate (task units per s)")
