"""The tasks of one hierarchy, evaluated together: their rows, frames and records
in two preallocated buffers.

:class:`TaskBatch` holds every task of an action set: its parameters packed into
arrays, one row block per task (value, Jacobian, activation, reference, error),
the world poses and Jacobians of the frames the tasks read (each frame once: the
tool Jacobian serves position and orientation, the camera's serves centering and
occlusion), the packed targets (``env``) and, per task, what the controller's
telemetry reports: when it was last stacked (``t_rec``, s) and with which
action-transition factor (``ap_rec``).

Every array is a view of one float64 buffer (``fbuf``) or one int64 buffer
(``ibuf``, its header first): :func:`batch_views` carves them again inside
compiled code, so the controller's cycle (:mod:`kcl.cycle`) takes the whole batch
as two arguments. :func:`run_task` dispatches to a task's row kernel by its
index in :data:`ROW_KERNELS`, the kernels of every registered task type.

Numba's cache of a function calling :func:`run_task` embeds every task's kernel
but is keyed on its own file only: :data:`KERNEL_SOURCES` lists the task modules
for :func:`kcl.jit.drop_stale`.
"""

from __future__ import annotations

import math
import sys
from collections.abc import Sequence

import numpy as np
from numba import literal_unroll

from kcl.buffers import take, take2, take3
from kcl.jit import drop_stale, njit
from kcl.tasks import TASK_TYPES
from kcl.tasks.base import Targets, Task, TaskOutput
from kcl.tasks.jit import ENV_SIZE, IDLE_NOTES, RowInputs, TaskRows, pack_env

#: the row kernel of every task type, indexed by :data:`KERNEL_INDEX`
ROW_KERNELS = tuple(cls.ROW_KERNEL for cls in TASK_TYPES.values())
#: task type -> index of its kernel in :data:`ROW_KERNELS`
KERNEL_INDEX = {name: i for i, name in enumerate(TASK_TYPES)}
#: the source files of the task modules (their kernels are embedded by callers of run_task)
KERNEL_SOURCES = [str(sys.modules[cls.__module__].__file__) for cls in TASK_TYPES.values()]
drop_stale(__file__, KERNEL_SOURCES)

#: :attr:`TaskBatch.status` of a task never evaluated
NEVER_EVALUATED = -1
#: task kinds in the int buffer
KIND_CODES = {"equality": 0, "inequality": 1, "velocity": 2}

HEADER = 7  # ibuf[:7] = (tasks, rows, n, frames, params width, frames width, frames state)
FRAMES_STATE = 6  # ibuf index: the state id the frames were computed at (-1: none)


@njit
def run_task(
    kid: int,
    p: np.ndarray,
    frames: np.ndarray,
    P: np.ndarray,
    Jw: np.ndarray,
    q: np.ndarray,
    eta: np.ndarray,
    wRv: np.ndarray,
    env: np.ndarray,
    x: np.ndarray,
    J: np.ndarray,
    a: np.ndarray,
    xdot: np.ndarray,
    err: np.ndarray,
) -> int:
    """Run kernel ``kid`` of :data:`ROW_KERNELS` (signature in :mod:`kcl.tasks.jit`);
    returns its status (-2 for an unknown index)."""
    inp = RowInputs(p, frames, P, Jw, q, eta, wRv, env)
    out = TaskRows(x, J, a, xdot, err)
    status = -2
    i = 0
    for kernel in literal_unroll(ROW_KERNELS):
        if i == kid:
            status = kernel(inp, out)
        i += 1
    return status


@njit
def batch_views(ibuf: np.ndarray, fbuf: np.ndarray) -> tuple[np.ndarray, ...]:
    """The arrays of a :class:`TaskBatch` from its two buffers: ``(kernel, kind,
    frames, row0, dims, status, stamp, X, J, A, XD, E, P, Jw, env, params, t_rec,
    ap_rec)``, views. ``ibuf[:7]`` = (tasks, rows, n, frames, params width,
    frames width, frames state)."""
    count, rows, n, nf, pw, fw = ibuf[0], ibuf[1], ibuf[2], ibuf[3], ibuf[4], ibuf[5]
    kernel, o = take(ibuf, HEADER, count)
    kind, o = take(ibuf, o, count)
    frames, o = take2(ibuf, o, count, fw)
    row0, o = take(ibuf, o, count)
    dims, o = take(ibuf, o, count)
    status, o = take(ibuf, o, count)
    stamp, o = take(ibuf, o, count)
    X, o = take(fbuf, 0, rows)
    J, o = take2(fbuf, o, rows, n)
    A, o = take(fbuf, o, rows)
    XD, o = take(fbuf, o, rows)
    E, o = take(fbuf, o, rows)
    P, o = take3(fbuf, o, nf, 4, 4)
    Jw, o = take3(fbuf, o, nf, 6, n)
    env, o = take(fbuf, o, ENV_SIZE)
    params, o = take2(fbuf, o, count, pw)
    t_rec, o = take(fbuf, o, count)
    ap_rec, o = take(fbuf, o, count)
    return kernel, kind, frames, row0, dims, status, stamp, X, J, A, XD, E, P, Jw, env, params, t_rec, ap_rec


class TaskBatch:
    """Every task of ``tasks`` (hierarchy order) with its rows (see module doc).
    ``index[name]`` is the slot of a task."""

    def __init__(self, tasks: Sequence[Task], n: int):
        self.tasks = list(tasks)
        self.index = {tk.name: k for k, tk in enumerate(self.tasks)}
        count = len(self.tasks)
        self.n = n
        frame_names: list[str] = []
        for tk in self.tasks:
            for f in tk.kernel_frames():
                if f not in frame_names:
                    frame_names.append(f)
        #: the frames the tasks read, in the order of P / Jw
        self.frame_names = tuple(frame_names)
        plist = [tk.kernel_params() for tk in self.tasks]
        flist = [[frame_names.index(f) for f in tk.kernel_frames()] for tk in self.tasks]
        dims = [tk.dim() for tk in self.tasks]
        pw = max([len(p) for p in plist], default=0) + 1
        fw = max([len(f) for f in flist], default=0) + 1
        rows = max(1, sum(dims))
        nf = max(1, len(frame_names))
        self.ibuf = np.zeros(HEADER + count * (fw + 6), dtype=np.int64)
        self.ibuf[:HEADER] = (count, rows, n, nf, pw, fw, -1)
        self.fbuf = np.zeros(rows * (n + 4) + nf * (16 + 6 * n) + ENV_SIZE + count * (pw + 2))
        (
            self.kernel,
            self.kind,
            self.frames,
            self.row0,
            self.dims,
            self.status,
            self.stamp,
            self.X,
            self.J,
            self.A,
            self.XD,
            self.E,
            self.P,
            self.Jw,
            self.env,
            self.params,
            self.t_rec,
            self.ap_rec,
        ) = batch_views(self.ibuf, self.fbuf)
        self.kernel[:] = [KERNEL_INDEX[tk.TYPE] for tk in self.tasks]
        self.kind[:] = [KIND_CODES[tk.KIND] for tk in self.tasks]
        for k, (task_params, task_frames) in enumerate(zip(plist, flist)):
            self.params[k, : len(task_params)] = task_params
            self.frames[k, : len(task_frames)] = task_frames
        self.dims[:] = dims
        if count:
            self.row0[1:] = np.cumsum(self.dims)[:-1]
        self.forget()
        self._env_targets: Targets | None = None
        self.slices = [slice(int(r), int(r + d)) for r, d in zip(self.row0, self.dims)]

    def forget(self) -> None:
        """Forget every evaluation and record (as a new batch)."""
        self.status[:] = NEVER_EVALUATED
        self.stamp[:] = -1
        self.t_rec[:] = math.nan
        self.ibuf[FRAMES_STATE] = -1

    def set_targets(self, targets: Targets) -> None:
        """Pack ``targets`` into ``env`` (when they are another object than last time:
        Targets are immutable). The altitude and the fed velocity are written by the
        cycle itself."""
        if targets is not self._env_targets:
            pack_env(self.env, targets, None)
            self._env_targets = targets

    def output(self, k: int) -> TaskOutput:
        """Task ``k``'s rows from its last evaluation (copies; zeros and the note
        for an idle task)."""
        status = int(self.status[k])
        if status == NEVER_EVALUATED:
            return self.tasks[k].idle("not evaluated yet")
        if status:
            return self.tasks[k].idle(IDLE_NOTES[status])
        s = self.slices[k]
        return TaskOutput(self.X[s].copy(), self.J[s].copy(), self.A[s].copy(), self.XD[s].copy(), self.E[s].copy())
