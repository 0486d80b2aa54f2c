"""Every compiled task of a control cycle in one call.

:class:`TaskBatch` holds, for the tasks that have a row kernel
(``Task.ROW_KERNEL``, see :mod:`kcl.tasks.jit`), their parameters packed into
arrays and one preallocated row buffer (value, Jacobian, activation, reference,
error). :meth:`TaskBatch.run` gathers the frame poses and world Jacobians the
selected tasks read (each frame once: the tool Jacobian serves position and
orientation, the camera's serves centering and occlusion), then one compiled
call (:func:`run_rows`) runs each selected task's kernel straight into its rows.
:meth:`TaskBatch.output` gives a task's rows as a :class:`TaskOutput` of views.

Every array of a batch is a view of one float64 buffer (``fbuf``) or one
int64 buffer (``ibuf``, its header first): :func:`batch_views` carves them
again inside compiled code, so :func:`kcl.arm_cycle.arm_cycle` takes the
whole batch as two arguments.

Rows of a task are rewritten only when it is selected, so views handed out
stay that task's last evaluation. Adding a compiled task: give it a row kernel
and a new ``KERNEL_ID``, and add its branch to :func:`run_rows`.

Numba caveat: the on-disk cache of :func:`run_rows` embeds every task's
kernel but Numba keys it on THIS file only; it is dropped at import when a
task module is newer (:func:`kcl.jit_cache.drop_stale`).
tests/kcl/test_task_kernels.py (batch == each task's own evaluate) checks it.
"""

from __future__ import annotations

import sys
from collections.abc import Sequence

import numpy as np

from kcl.jit_cache import drop_stale
from kcl.model import Kinematics
from kcl.tasks.altitude import altitude_rows
from kcl.tasks.arm_velocity_minimization import arm_stop_rows
from kcl.tasks.base import Targets, Task, TaskOutput
from kcl.tasks.camera_centering import camera_centering_rows
from kcl.tasks.horizontal_attitude import horizontal_attitude_rows
from kcl.tasks.jit import ENV_SIZE, IDLE_NOTES, SHARED_SOURCES, njit, pack_env, set_env_altitude, set_env_velocity
from kcl.tasks.joint_limits import joint_limits_rows
from kcl.tasks.manipulability import manipulability_rows
from kcl.tasks.occlusion import occlusion_rows
from kcl.tasks.preferred_shape import preferred_shape_rows
from kcl.tasks.tool_orientation import tool_orientation_rows
from kcl.tasks.tool_position import tool_position_rows
from kcl.tasks.vehicle_pose import vehicle_pose_rows
from kcl.tasks.vehicle_velocity_minimization import vehicle_stop_rows

_KERNELS = (
    tool_position_rows,
    tool_orientation_rows,
    camera_centering_rows,
    occlusion_rows,
    altitude_rows,
    horizontal_attitude_rows,
    joint_limits_rows,
    preferred_shape_rows,
    manipulability_rows,
    arm_stop_rows,
    vehicle_stop_rows,
    vehicle_pose_rows,
)
# run_rows embeds every kernel (and what they call): recompile it when one changed
#: the task modules whose kernels run_rows embeds
KERNEL_SOURCES = [sys.modules[getattr(k, "py_func", k).__module__].__file__ for k in _KERNELS]
drop_stale(__file__, KERNEL_SOURCES + SHARED_SOURCES)


@njit
def run_rows(ids, params, frames, row0, dims, selected, P, Jw, q, eta, wRv, env, X, J, A, XD, E, status):
    """Run the kernel of every selected task k (branch ``ids[k]``) on its rows
    ``row0[k] : row0[k] + dims[k]`` of X, J, A, XD, E (zeroed first); its
    status goes to ``status[k]``."""
    for k in range(ids.shape[0]):
        if not selected[k]:
            continue
        r0 = row0[k]
        r1 = r0 + dims[k]
        X[r0:r1] = 0.0
        J[r0:r1] = 0.0
        A[r0:r1] = 0.0
        XD[r0:r1] = 0.0
        E[r0:r1] = 0.0
        x, j, a, xd, e = X[r0:r1], J[r0:r1], A[r0:r1], XD[r0:r1], E[r0:r1]
        p, f = params[k], frames[k]
        kid = ids[k]
        if kid == 1:
            s = tool_position_rows(p, f, P, Jw, q, eta, wRv, env, x, j, a, xd, e)
        elif kid == 2:
            s = tool_orientation_rows(p, f, P, Jw, q, eta, wRv, env, x, j, a, xd, e)
        elif kid == 3:
            s = camera_centering_rows(p, f, P, Jw, q, eta, wRv, env, x, j, a, xd, e)
        elif kid == 4:
            s = occlusion_rows(p, f, P, Jw, q, eta, wRv, env, x, j, a, xd, e)
        elif kid == 5:
            s = altitude_rows(p, f, P, Jw, q, eta, wRv, env, x, j, a, xd, e)
        elif kid == 6:
            s = horizontal_attitude_rows(p, f, P, Jw, q, eta, wRv, env, x, j, a, xd, e)
        elif kid == 7:
            s = joint_limits_rows(p, f, P, Jw, q, eta, wRv, env, x, j, a, xd, e)
        elif kid == 8:
            s = preferred_shape_rows(p, f, P, Jw, q, eta, wRv, env, x, j, a, xd, e)
        elif kid == 9:
            s = manipulability_rows(p, f, P, Jw, q, eta, wRv, env, x, j, a, xd, e)
        elif kid == 10:
            s = arm_stop_rows(p, f, P, Jw, q, eta, wRv, env, x, j, a, xd, e)
        elif kid == 11:
            s = vehicle_stop_rows(p, f, P, Jw, q, eta, wRv, env, x, j, a, xd, e)
        elif kid == 12:
            s = vehicle_pose_rows(p, f, P, Jw, q, eta, wRv, env, x, j, a, xd, e)
        else:
            s = -1
        if s != 0:  # idle: rows back to zero (like Task.idle)
            X[r0:r1] = 0.0
            J[r0:r1] = 0.0
            A[r0:r1] = 0.0
            XD[r0:r1] = 0.0
            E[r0:r1] = 0.0
        status[k] = s


_HEADER = 6  # ibuf[:6] = (tasks, rows, n, frames, params width, frames width)


class _Carver:
    """Consecutive C-contiguous views of one flat buffer."""

    def __init__(self, buf: np.ndarray, start: int):
        self.buf = buf
        self.pos = start

    def take(self, shape: tuple[int, ...]) -> np.ndarray:
        size = int(np.prod(shape))
        view = self.buf[self.pos : self.pos + size].reshape(shape)
        self.pos += size
        return view


@njit
def batch_views(ibuf, fbuf):
    """The arrays of a :class:`TaskBatch` from its two buffers (same layout as
    its constructor): ``(ids, frames, row0, dims, status, X, J, A, XD, E, P,
    Jw, Jraw, env, params)``, views (Jraw: Pinocchio's column order)."""
    count, rows, n, nf, pw, fw = ibuf[0], ibuf[1], ibuf[2], ibuf[3], ibuf[4], ibuf[5]
    o = 6
    ids = ibuf[o : o + count]
    o += count
    frames = ibuf[o : o + count * fw].reshape((count, fw))
    o += count * fw
    row0 = ibuf[o : o + count]
    o += count
    dims = ibuf[o : o + count]
    o += count
    status = ibuf[o : o + count]
    X = fbuf[0:rows]
    o = rows
    J = fbuf[o : o + rows * n].reshape((rows, n))
    o += rows * n
    A = fbuf[o : o + rows]
    o += rows
    XD = fbuf[o : o + rows]
    o += rows
    E = fbuf[o : o + rows]
    o += rows
    P = fbuf[o : o + nf * 16].reshape((nf, 4, 4))
    o += nf * 16
    Jw = fbuf[o : o + nf * 6 * n].reshape((nf, 6, n))
    o += nf * 6 * n
    Jraw = fbuf[o : o + nf * 6 * n].reshape((nf, 6, n))
    o += nf * 6 * n
    env = fbuf[o : o + ENV_SIZE]
    o += ENV_SIZE
    params = fbuf[o : o + count * pw].reshape((count, pw))
    return ids, frames, row0, dims, status, X, J, A, XD, E, P, Jw, Jraw, env, params


class TaskBatch:
    """The compiled tasks among ``tasks``, evaluated together (see module doc).

    ``index[name]`` is the batch slot of a task, absent for tasks without a
    row kernel (the caller evaluates those in Python).
    """

    def __init__(self, tasks: Sequence[Task], n: int):
        chosen = [tk for tk in tasks if tk.ROW_KERNEL is not None]
        self.tasks = chosen
        self.index = {tk.name: k for k, tk in enumerate(chosen)}
        count = len(chosen)
        self.n = n
        self.frame_names: list[str] | tuple[str, ...] = []
        for tk in chosen:
            for f in tk.kernel_frames():
                if f not in self.frame_names:
                    self.frame_names.append(f)
        plist = [tk.kernel_params() for tk in chosen]
        flist = [[self.frame_names.index(f) for f in tk.kernel_frames()] for tk in chosen]
        dims = [tk.dim() for tk in chosen]
        pw = max([len(p) for p in plist], default=0) + 1
        fw = max([len(f) for f in flist], default=0) + 1
        rows = max(1, sum(dims))
        nf = max(1, len(self.frame_names))
        # every array lives in one float64 and one int64 buffer (views), so a
        # compiled call can take the whole batch as two arguments (batch_views)
        self.ibuf = ibuf = np.zeros(_HEADER + count * (fw + 4), dtype=np.int64)
        ibuf[:_HEADER] = (count, rows, n, nf, pw, fw)
        self.fbuf = fbuf = np.zeros(rows * (n + 4) + nf * (16 + 12 * n) + ENV_SIZE + count * pw)
        ints = _Carver(ibuf, _HEADER)
        self.ids = ints.take((count,))
        self.frames = ints.take((count, fw))
        self.row0 = ints.take((count,))
        self.dims = ints.take((count,))
        self.status = ints.take((count,))
        floats = _Carver(fbuf, 0)
        self.X = floats.take((rows,))
        self.J = floats.take((rows, n))
        self.A = floats.take((rows,))
        self.XD = floats.take((rows,))
        self.E = floats.take((rows,))
        self.P = floats.take((nf, 4, 4))
        self.Jw = floats.take((nf, 6, n))
        self._Jraw = floats.take((nf, 6, n))  # Pinocchio's column order (Kinematics.frames_into)
        self.env = floats.take((ENV_SIZE,))
        self.params = floats.take((count, pw))
        self.ids[:] = [tk.KERNEL_ID for tk in chosen]
        for k, (p, f) in enumerate(zip(plist, flist)):
            self.params[k, : len(p)] = p
            self.frames[k, : len(f)] = f
        self.task_frames = [tuple(fl) for fl in flist]
        self.dims[:] = dims
        if count:
            self.row0[1:] = np.cumsum(self.dims)[:-1]
        self.selected = np.zeros(count, dtype=bool)
        self.frame_names = tuple(self.frame_names)  # (Kinematics.frames_into keys its frame ids on it)
        #: per-frame views of P and of the raw Jacobians (Kinematics.frames_into's ``rows``)
        self.frame_rows = (list(self.P), list(self._Jraw))
        self._env_targets: Targets | None = None  # what env holds
        self._env_altitude: float | None = None
        # one TaskOutput of views per task, built once: a run rewrites the rows
        self._views = [
            TaskOutput(self.X[s], self.J[s], self.A[s], self.XD[s], self.E[s])
            for s in (slice(int(r), int(r + d)) for r, d in zip(self.row0, self.dims))
        ]

    def run(
        self,
        kin: Kinematics,
        targets: Targets,
        altitude: float | None,
        frames: set[int] | None = None,
        velocity: np.ndarray | None = None,
    ) -> None:
        """Evaluate the tasks whose ``selected`` flag is set (set it before);
        ``frames``: the union of their ``task_frames`` (None: every frame);
        ``velocity``: the vehicle velocity fed to the TPIK (``TaskContext.v``)."""
        sel = self.selected
        kin.frames_into(
            self.frame_names,
            range(len(self.frame_names)) if frames is None else frames,
            self.P,
            self.Jw,
            self._Jraw,
            rows=self.frame_rows,
        )
        self.set_env(targets, altitude)
        set_env_velocity(self.env, velocity)
        run_rows(
            self.ids,
            self.params,
            self.frames,
            self.row0,
            self.dims,
            sel,
            self.P,
            self.Jw,
            kin.q,
            kin.eta,
            kin.wRv,
            self.env,
            self.X,
            self.J,
            self.A,
            self.XD,
            self.E,
            self.status,
        )

    def set_env(self, targets: Targets, altitude: float | None) -> None:
        """Bring ``env`` (the kernels' targets and altitude) up to date."""
        if targets is not self._env_targets:  # Targets are immutable: same object, same values
            pack_env(self.env, targets, altitude)
            self._env_targets, self._env_altitude = targets, altitude
        elif altitude != self._env_altitude:  # the usual cycle: only the altitude moved
            set_env_altitude(self.env, altitude)
            self._env_altitude = altitude

    def output(self, k: int) -> TaskOutput:
        """Task ``k``'s rows from the last run that selected it (views, the
        same object every time: it changes when the task is run again)."""
        status = int(self.status[k])
        if status:
            return self.tasks[k].idle(IDLE_NOTES[status])
        return self._views[k]

    def outputs_into(self, out: dict[str, TaskOutput], chosen: list[tuple[str, int]]) -> None:
        """``out[name] = self.output(k)`` for each ``(name, k)`` of ``chosen``."""
        status = self.status.tolist()
        views = self._views
        for name, k in chosen:
            s = status[k]
            out[name] = self.tasks[k].idle(IDLE_NOTES[s]) if s else views[k]

    def warm_up(self, kin: Kinematics) -> None:
        """Load (first time: compile) the kernels by running every task once."""
        self.selected[:] = True
        self.run(kin, Targets(tool_goal=np.eye(4)), 1.0)
        self.selected[:] = False


@njit
def gather_rows(
    slots, level_of, inequality, status, row0, dims, A, J, XD, arm_only, v_top, SJ, Sa, Sx, start, level_rows, slot_row
):
    """Copy the rows of batch tasks ``slots`` (hierarchy order; ``level_of``:
    their level) into a stack (SJ, Sa, Sx) from row ``start``, skipping idle
    tasks and inequality tasks whose activations are all zero. arm_only
    (TPIK 2): joint columns only and ``xdot - J_v v_top`` (v_top: (6,) vehicle
    velocity). Adds each level's row count to ``level_rows``; ``slot_row[i]``
    = first stack row of slot i, -1 if skipped. Returns the next free row."""
    p = start
    l = SJ.shape[1] if arm_only else SJ.shape[1] - 6
    for i in range(slots.shape[0]):
        k = slots[i]
        slot_row[i] = -1
        if status[k] != 0:
            continue
        r0 = row0[k]
        m = dims[k]
        if inequality[i]:
            active = False
            for r in range(r0, r0 + m):
                if A[r] != 0.0:  # (NaN counts as active: the solver refuses it)
                    active = True
            if not active:
                continue
        slot_row[i] = p
        for r in range(m):
            Sa[p + r] = A[r0 + r]
            if arm_only:
                for c in range(l):
                    SJ[p + r, c] = J[r0 + r, c]
                acc = 0.0
                for c in range(6):
                    acc += J[r0 + r, l + c] * v_top[c]
                Sx[p + r] = XD[r0 + r] - acc
            else:
                for c in range(l + 6):
                    SJ[p + r, c] = J[r0 + r, c]
                Sx[p + r] = XD[r0 + r]
        level_rows[level_of[i]] += m
        p += m
    return p


@njit
def copy_arm_rows(bounds, n_blocks, v_top, J1, a1, x1, J2, a2, x2):
    """TPIK 2's rows from TPIK 1's stack (J1, a1, x1; n = l + 6 columns): the
    row blocks ``bounds[:n_blocks]`` ([start, stop) each), joint columns only,
    ``xdot - J_v v_top`` (v_top: (6,) vehicle velocity), written from row 0 of
    (J2, a2, x2). Returns the number of rows written."""
    l = J2.shape[1]
    k = 0
    for b in range(n_blocks):
        for i in range(bounds[b, 0], bounds[b, 1]):
            for c in range(l):
                J2[k, c] = J1[i, c]
            a2[k] = a1[i]
            acc = 0.0
            for c in range(6):
                acc += J1[i, l + c] * v_top[c]
            x2[k] = x1[i] - acc
            k += 1
    return k
