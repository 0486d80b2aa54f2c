"""Base of every control task of the KCL.

A task turns the current state (a :class:`~kcl.model.Kinematics` snapshot plus
targets and a few measurements, bundled in :class:`TaskContext`) into one
:class:`TaskOutput`: its value ``x``, Jacobian ``J`` (m x n, w.r.t.
``ydot = [qdot; v]``), activation ``a`` in [0, 1]^m (inequality bells only; the
action-transition factor is applied by the controller), reference rate ``xdot``
and an error to log. Tasks are stateless: parameters are fixed at construction
(they come from the actions YAML), everything else arrives in the context.

A task is one module of :mod:`kcl.tasks`: its class (``TYPE``, ``KIND``,
``PARAMS``, ``dim()``, and what its kernel reads: ``kernel_params()``,
``kernel_frames()``) and, beside it, its compiled *row kernel* (``ROW_KERNEL``,
signature in :mod:`kcl.tasks.jit`). Defining the class registers it
(:data:`TASK_REGISTRY`, by ``TYPE``); the controller runs every task's kernel in
one compiled call per step (:mod:`kcl.tasks.batch`) and :meth:`Task.evaluate`
runs it on one task, so the code the tests check (finite differences,
activations) is the code the controller runs. ``docs/architecture.md`` has the
recipe for a new task.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any, ClassVar

import numpy as np

from kcl.model import Kinematics, UvmsModel
from kcl.tasks.jit import ENV_SIZE, IDLE_NOTES, RowInputs, TaskRows, pack_env, set_env_velocity


@dataclass(frozen=True)
class Targets:
    """What the tasks aim at (all optional; a task without its target is inactive).

    tool_goal: (4, 4) world pose the tool frame must reach (grasp frame).
    vehicle_goal: (4,) ``[x, y, z, yaw]`` world NED, m and rad.
    camera_target: (3,) world point the stereo camera keeps centred (defaults to
    the tool goal's origin when None).
    tool_velocity: (6,) commanded tool twist ``[vx vy vz wx wy wz]`` (m/s, rad/s),
    e.g. an operator's jog; its frame is a parameter of the task that follows it.
    vehicle_velocity: (6,) commanded body velocity ``[u v w p q r]`` (m/s, rad/s,
    vehicle frame), e.g. an operator's jog of the vehicle.
    geofence: (3, 2) ``[[north lo, hi], [east lo, hi], [down lo, hi]]`` world NED
    box (m) the vehicle must stay in.
    """

    tool_goal: np.ndarray | None = None
    vehicle_goal: np.ndarray | None = None
    camera_target: np.ndarray | None = None
    tool_velocity: np.ndarray | None = None
    vehicle_velocity: np.ndarray | None = None
    geofence: np.ndarray | None = None

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
    """

    kin: Kinematics
    targets: Targets = field(default_factory=Targets)
    altitude: float | None = None
    v: np.ndarray | None = None


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

    kind: ``positive`` / ``nonneg`` / ``any`` (float), ``posture`` (list of l
    floats or nulls), ``frame`` (a frame role or URDF frame name), ``bool``.
    """

    default: Any
    kind: str
    doc: str


#: the Param kinds handed to row kernels by default (numbers, and bools as 0/1)
_KERNEL_PARAM_KINDS = ("positive", "nonneg", "any", "bool")

#: YAML ``type:`` name -> task class, filled as task classes are defined
TASK_REGISTRY: dict[str, type[Task]] = {}


class Task(ABC):
    """A control task. Subclasses set ``TYPE``, ``KIND``, ``PARAMS``,
    ``ROW_KERNEL`` and the flags ``USES_ARM`` / ``USES_VEHICLE`` (which ydot
    columns the Jacobian can touch)."""

    TYPE: ClassVar[str] = ""
    #: "equality", "inequality" (rows may be inactive) or "velocity" (reads the
    #: vehicle velocity fed to the TPIK, so it is evaluated again by each TPIK)
    KIND: ClassVar[str] = "equality"
    PARAMS: ClassVar[dict[str, Param]] = {}
    #: whether the Jacobian can have arm / vehicle columns (a task may set them per instance)
    USES_ARM: bool = True
    USES_VEHICLE: bool = True
    #: compiled row kernel (signature in kcl.tasks.jit)
    ROW_KERNEL: ClassVar[Callable[..., int]]

    def __init_subclass__(cls, **kwargs: Any) -> None:
        super().__init_subclass__(**kwargs)
        if not cls.TYPE:
            raise TypeError(f"{cls.__name__}: a task needs a TYPE (its name in the actions YAML)")
        if cls.KIND not in ("equality", "inequality", "velocity"):
            raise TypeError(f"{cls.__name__}: KIND must be equality, inequality or velocity, not {cls.KIND!r}")
        if getattr(cls, "ROW_KERNEL", None) is None:
            raise TypeError(f"{cls.__name__}: a task needs a compiled ROW_KERNEL (kcl.tasks.jit)")
        known = TASK_REGISTRY.get(cls.TYPE)
        if known is not None and known.__qualname__ != cls.__qualname__:
            raise TypeError(f"task type {cls.TYPE!r} is defined twice: {known.__qualname__} and {cls.__qualname__}")
        TASK_REGISTRY[cls.TYPE] = cls

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

    def kernel_params(self) -> list[float]:
        """The float parameters ``p`` of :attr:`ROW_KERNEL`: by default the task's
        number and bool parameters (0/1), in the order of ``PARAMS``."""
        return [float(self.params[k]) for k, spec in self.PARAMS.items() if spec.kind in _KERNEL_PARAM_KINDS]

    def kernel_frames(self) -> list[str]:
        """The frames (roles or URDF names) :attr:`ROW_KERNEL` reads: by default the
        task's frame parameters, in the order of ``PARAMS``."""
        return [self.params[k] for k, spec in self.PARAMS.items() if spec.kind == "frame"]

    def evaluate(self, ctx: TaskContext) -> TaskOutput:
        """The task at the state in ``ctx``: :attr:`ROW_KERNEL` run on this task
        alone (the code the controller's batch runs), on Pinocchio's frames."""
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
        inp = RowInputs(
            np.array(self.kernel_params(), dtype=float),
            np.arange(len(frames), dtype=np.int64),
            P,
            Jw,
            np.ascontiguousarray(kin.q, dtype=float),
            np.ascontiguousarray(kin.eta, dtype=float),
            np.ascontiguousarray(kin.wRv),
            env,
        )
        status = type(self).ROW_KERNEL(inp, TaskRows(x, J, a, xdot, err))
        if status:
            return self.idle(IDLE_NOTES[status])
        return TaskOutput(x, J, a, xdot, err)

    def idle(self, note: str) -> TaskOutput:
        """Output of a task that cannot run now (activation zero, reason in ``note``)."""
        m = self.dim()
        z = np.zeros(m)
        return TaskOutput(z, np.zeros((m, self.n)), z.copy(), z.copy(), z.copy(), note)

    def __repr__(self) -> str:
        return f"{type(self).__name__}({self.name!r})"


# common parameters
GAIN = Param(1.0, "positive", "gain gamma of the reactive reference, 1/s")
MAX_RATE = Param(float("inf"), "positive", "saturation of the reference rate (task units per s)")
