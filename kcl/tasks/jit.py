"""Shared pieces of the tasks' compiled row kernels.

Several tasks hold, next to their Python description, a *row kernel*: a Numba
function with one common signature that writes the task's rows (value ``x``,
Jacobian ``J``, activation ``a``, reference ``xdot``, error ``err``) into
arrays given by the caller and returns a status (0 = running, else one of the
``IDLE_*`` codes, whose text is :data:`IDLE_NOTES`). The same kernel serves
:meth:`Task.evaluate` (one task, its own small arrays) and the controller's
per-cycle batch (:mod:`kcl.tasks.batch`: every task of the cycle in one
compiled call, rows written straight into one preallocated buffer).

Common kernel signature::

    rows(p, frames, P, Jw, q, eta, wRv, env, x, J, a, xdot, err) -> int

p: float64 parameters of the task (its ``kernel_params()``); frames: int64
indices into P / Jw of the frames it reads (its ``kernel_frames()``);
P: (F, 4, 4) world poses; Jw: (F, 6, n) world Jacobians w.r.t.
``[qdot; v]``; q (l,) rad; eta (6,) ``[x y z roll pitch yaw]`` world NED;
wRv (3, 3); env: targets and measurements packed by :func:`pack_env`.
Outputs must be zero on entry except where the kernel writes (idle tasks
leave them zero, like :meth:`Task.idle`).

Without Numba the kernels run as plain Python (same results, slower).
"""

from __future__ import annotations

import math
import sys
from pathlib import Path

import numpy as np

from kcl.jit_cache import KERNEL_OPTIONS, drop_stale

#: source files whose compiled functions the row kernels call
SHARED_SOURCES = [__file__, str(Path(__file__).resolve().parents[1] / "small_linalg.py")]

try:  # Numba is a dependency; the plain-Python fallback keeps tests runnable without it
    import numba

    def njit(fn):
        """``numba.njit(**KERNEL_OPTIONS)`` (cached, the interpreter lock held:
        :data:`kcl.jit_cache.KERNEL_OPTIONS`), after dropping the cache of
        ``fn``'s module if it is older than this file or kcl/small_linalg.py,
        whose compiled helpers the kernels call (:mod:`kcl.jit_cache`)."""
        drop_stale(sys.modules[fn.__module__].__file__, SHARED_SOURCES)
        return numba.njit(**KERNEL_OPTIONS)(fn)

    HAVE_NUMBA = True
except ImportError:  # pragma: no cover

    def njit(fn):
        return fn

    HAVE_NUMBA = False

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
ENV_SIZE = 34

IDLE_NO_TOOL_GOAL = 1
IDLE_NO_CAMERA_TARGET = 2
IDLE_NO_ALTITUDE = 3
IDLE_NO_VEHICLE_GOAL = 4
IDLE_NOTES = {
    0: "",
    IDLE_NO_TOOL_GOAL: "no tool_goal",
    IDLE_NO_CAMERA_TARGET: "no camera target",
    IDLE_NO_ALTITUDE: "no altitude measurement",
    IDLE_NO_VEHICLE_GOAL: "no vehicle_goal",
}


def pack_env(out: np.ndarray, targets, altitude: float | None) -> np.ndarray:
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
def increasing_bell(x: float, xmin: float, xmax: float) -> float:
    """Scalar :func:`kcl.activation.increasing_bell` (NaN in, NaN out)."""
    if x <= xmin:
        return 0.0
    if x >= xmax:
        return 1.0
    if x != x:
        return math.nan
    return 0.5 - 0.5 * math.cos(math.pi * (x - xmin) / (xmax - xmin))


@njit
def decreasing_bell(x: float, xmin: float, xmax: float) -> float:
    """Scalar :func:`kcl.activation.decreasing_bell` (NaN in, NaN out)."""
    if x <= xmin:
        return 1.0
    if x >= xmax:
        return 0.0
    if x != x:
        return math.nan
    return 0.5 * math.cos(math.pi * (x - xmin) / (xmax - xmin)) + 0.5


@njit
def saturate_into(xdot: np.ndarray, err: np.ndarray, gain: float, limit: float) -> None:
    """``xdot = gain * err`` scaled uniformly so no entry exceeds ``limit``
    (same as :func:`kcl.tasks.base.saturate`)."""
    peak = 0.0
    for i in range(err.shape[0]):
        xdot[i] = gain * err[i]
        if abs(xdot[i]) > peak:
            peak = abs(xdot[i])
    if limit != math.inf and peak > limit:
        s = limit / peak
        for i in range(err.shape[0]):
            xdot[i] = xdot[i] * s
