"""What the tasks' compiled row kernels share: the signature, the packed
targets (``env``), the idle codes, the activation bells and the saturation.

Every task holds, next to its Python description, a *row kernel*: a compiled
function that writes the task's rows (value ``x``, Jacobian ``J``, activation
``a``, reference ``xdot``, error ``err``) into arrays given by the caller and
returns a status (0 = running, else one of the ``IDLE_*`` codes, whose text is
:data:`IDLE_NOTES`). The same kernel serves :meth:`kcl.tasks.base.Task.evaluate`
(one task, its own small arrays) and the controller's cycle (every task of the
step in one compiled call, rows written straight into the task batch,
:mod:`kcl.tasks.batch`).

Signature::

    rows(inp: RowInputs, out: TaskRows) -> int

(:class:`RowInputs` and :class:`TaskRows` say what each array holds). The
outputs are zero on entry; an idle task leaves them zero.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, NamedTuple

import numpy as np

from kcl.activation import decreasing_bell, increasing_bell
from kcl.jit import njit

if TYPE_CHECKING:
    from kcl.tasks.base import Targets


class RowInputs(NamedTuple):
    """What a row kernel reads (compiled code takes named tuples, not dataclasses)."""

    #: float64 parameters of the task (its ``kernel_params()``)
    p: np.ndarray
    #: int64 indices into ``P`` / ``Jw`` of the frames it reads (its ``kernel_frames()``)
    frames: np.ndarray
    #: (F, 4, 4) world poses of the frames
    P: np.ndarray
    #: (F, 6, n) world Jacobians of the frames w.r.t. ``[qdot; v]``, joints first
    Jw: np.ndarray
    #: (l,) joint positions, rad
    q: np.ndarray
    #: (6,) vehicle pose ``[x y z roll pitch yaw]``, world NED (m, rad)
    eta: np.ndarray
    #: (3, 3) vehicle rotation, vehicle to world
    wRv: np.ndarray
    #: targets and measurements packed by :func:`pack_env`
    env: np.ndarray


class TaskRows(NamedTuple):
    """The m rows a row kernel writes (views into the caller's arrays)."""

    #: (m,) task value, task units
    x: np.ndarray
    #: (m, n) task Jacobian w.r.t. ``[qdot; v]``
    J: np.ndarray
    #: (m,) activation, 0..1
    a: np.ndarray
    #: (m,) reference rate, task units per s
    xdot: np.ndarray
    #: (m,) error the reference acts on, task units
    err: np.ndarray


# env layout (float64 vector)
ENV_HAS_ALTITUDE = 0
ENV_ALTITUDE = 1
ENV_HAS_TOOL_GOAL = 2
ENV_TOOL_GOAL = 3  # 16 entries, row-major 4x4 world pose
ENV_HAS_CAMERA_POINT = 19
ENV_CAMERA_POINT = 20  # 3 entries, world NED, m
ENV_HAS_VEHICLE_GOAL = 23
ENV_VEHICLE_GOAL = 24  # 4 entries [x y z yaw]
ENV_VELOCITY = 28  # 6 entries: the vehicle velocity fed to the TPIK (TaskContext.v; zeros when None)
ENV_HAS_TOOL_VELOCITY = 34
ENV_TOOL_VELOCITY = 35  # 6 entries [vx vy vz wx wy wz], m/s and rad/s
ENV_HAS_VEHICLE_VELOCITY = 41
ENV_VEHICLE_VELOCITY = 42  # 6 entries [u v w p q r], m/s and rad/s, vehicle frame
ENV_HAS_GEOFENCE = 48
ENV_GEOFENCE = 49  # 6 entries [north lo, north hi, east lo, east hi, down lo, down hi], m
ENV_SIZE = 55

IDLE_NO_TOOL_GOAL = 1
IDLE_NO_CAMERA_TARGET = 2
IDLE_NO_ALTITUDE = 3
IDLE_NO_VEHICLE_GOAL = 4
IDLE_NO_TOOL_VELOCITY = 5
IDLE_NO_VEHICLE_VELOCITY = 6
IDLE_NO_GEOFENCE = 7
IDLE_GEOFENCE_TOO_SMALL = 8
IDLE_NOTES = {
    0: "",
    IDLE_NO_TOOL_GOAL: "no tool_goal",
    IDLE_NO_CAMERA_TARGET: "no camera target",
    IDLE_NO_ALTITUDE: "no altitude measurement",
    IDLE_NO_VEHICLE_GOAL: "no vehicle_goal",
    IDLE_NO_TOOL_VELOCITY: "no tool_velocity command",
    IDLE_NO_VEHICLE_VELOCITY: "no vehicle_velocity command",
    IDLE_NO_GEOFENCE: "no geofence",
    IDLE_GEOFENCE_TOO_SMALL: "geofence smaller than twice its margin and width",
}


def pack_env(out: np.ndarray, targets: Targets, altitude: float | None) -> np.ndarray:
    """Write targets (:class:`kcl.tasks.Targets`) and the measured altitude (m,
    None if unknown) into ``out`` (ENV_SIZE,), the kernels' ``env`` (the
    velocity part zero: :func:`set_env_velocity`)."""
    out[:] = 0.0
    set_env_altitude(out, altitude)
    goal = targets.tool_goal
    if goal is not None:
        out[ENV_HAS_TOOL_GOAL] = 1.0
        out[ENV_TOOL_GOAL : ENV_TOOL_GOAL + 16] = np.asarray(goal, dtype=float).reshape(16)
    point = targets.camera_point()
    if point is not None:
        out[ENV_HAS_CAMERA_POINT] = 1.0
        out[ENV_CAMERA_POINT : ENV_CAMERA_POINT + 3] = point
    vgoal = targets.vehicle_goal
    if vgoal is not None:
        out[ENV_HAS_VEHICLE_GOAL] = 1.0
        out[ENV_VEHICLE_GOAL : ENV_VEHICLE_GOAL + 4] = vgoal
    twist = targets.tool_velocity
    if twist is not None:
        out[ENV_HAS_TOOL_VELOCITY] = 1.0
        out[ENV_TOOL_VELOCITY : ENV_TOOL_VELOCITY + 6] = twist
    body = targets.vehicle_velocity
    if body is not None:
        out[ENV_HAS_VEHICLE_VELOCITY] = 1.0
        out[ENV_VEHICLE_VELOCITY : ENV_VEHICLE_VELOCITY + 6] = body
    fence = targets.geofence
    if fence is not None:
        out[ENV_HAS_GEOFENCE] = 1.0
        out[ENV_GEOFENCE : ENV_GEOFENCE + 6] = np.asarray(fence, dtype=float).reshape(6)
    return out


def set_env_velocity(out: np.ndarray, v: np.ndarray | None) -> None:
    """Write the vehicle velocity fed to the TPIK (``TaskContext.v``, (6,), vehicle
    frame; None: zeros) into a packed ``env``."""
    out[ENV_VELOCITY : ENV_VELOCITY + 6] = 0.0 if v is None else v


def set_env_altitude(out: np.ndarray, altitude: float | None) -> None:
    """Write only the measured altitude (m, None if unknown) into a packed ``env``."""
    if altitude is None:
        out[ENV_HAS_ALTITUDE] = 0.0
        out[ENV_ALTITUDE] = 0.0
    else:
        out[ENV_HAS_ALTITUDE] = 1.0
        out[ENV_ALTITUDE] = altitude


@njit
def saturate_into(xdot: np.ndarray, err: np.ndarray, gain: float, limit: float) -> None:
    """``xdot = gain * err`` scaled uniformly so no entry exceeds ``limit``
    (direction kept)."""
    peak = 0.0
    for i in range(err.shape[0]):
        xdot[i] = gain * err[i]
        if abs(xdot[i]) > peak:
            peak = abs(xdot[i])
    if limit != math.inf and peak > limit:
        s = limit / peak
        for i in range(err.shape[0]):
            xdot[i] = xdot[i] * s


@njit
def twist_into(xdot: np.ndarray, x: np.ndarray, max_linear: float, max_angular: float) -> None:
    """``xdot`` = the twist ``x`` ``[linear (3); angular (3)]``, scaled down as a whole
    (direction kept) until no linear entry exceeds ``max_linear`` and no angular
    one ``max_angular``."""
    peak_lin = max(abs(x[0]), abs(x[1]), abs(x[2]))
    peak_ang = max(abs(x[3]), abs(x[4]), abs(x[5]))
    scale = 1.0
    if peak_lin > max_linear:
        scale = max_linear / peak_lin
    if peak_ang > max_angular:
        scale = min(scale, max_angular / peak_ang)
    for i in range(6):
        xdot[i] = x[i] * scale


@njit
def lower_bound_row(value: float, lo: float, width: float, x: np.ndarray, a: np.ndarray, err: np.ndarray) -> None:
    """Row 0 of an inequality task that keeps ``value`` above ``lo``: active below
    ``lo + width`` (decreasing bell), error towards ``lo + width`` where active."""
    xbar = lo + width
    x[0] = value
    a[0] = decreasing_bell(value, lo, xbar)
    err[0] = xbar - value if a[0] > 0.0 else 0.0


@njit
def upper_bound_row(value: float, hi: float, width: float, x: np.ndarray, a: np.ndarray, err: np.ndarray) -> None:
    """Row 0 of an inequality task that keeps ``value`` below ``hi``: active above
    ``hi - width`` (increasing bell), error towards ``hi - width`` where active."""
    xbar = hi - width
    x[0] = value
    a[0] = increasing_bell(value, xbar, hi)
    err[0] = xbar - value if a[0] > 0.0 else 0.0
