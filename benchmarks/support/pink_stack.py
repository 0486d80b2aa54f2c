"""The grasp action written for pin-pink, the baseline of benchmarks/kcl_cycle.py.

Pink (https://github.com/stephane-caron/pink) solves differential IK as ONE
quadratic program per cycle over the Pinocchio free-flyer model of the same
URDF (13 DOF: 6 vehicle body velocities, 7 joints), with daqp as QP solver:

* cost (weighted least squares, soft priorities by weight): the tool frame
  pose (``FrameTask``, 6 rows) and the grasp preferred shape (``PostureTask``,
  7 rows, weight 1e-2), plus pink's Tikhonov ``damping`` on all 13 velocities
  (the counterpart of iCAT's final minimum-velocity level; no rows built);
* hard constraints: the joint limits shrunk by the joint-limit task's margin
  (``ConfigurationLimit``, 7 x 2 rows), the joint and vehicle velocity limits
  (``VelocityLimit``, 13 x 2 rows) and, with ``full=True``, one control
  barrier function row (pink ``Barrier``, h(q) >= 0) for each of the other
  inequality tasks of the grasp action: manipulability (1 row), elbow-camera
  occlusion (1), camera centering (1), altitude (1), horizontal attitude (2).
  The barriers are written here against pink's API in numpy, as a pink user
  would write them (pink has no such tasks); their maths are those of
  kcl/tasks/ (same frames, same thresholds).

What is NOT equivalent: pink solves one weighted QP, not a strict hierarchy;
inequality objectives are hard constraints (always in the QP), not tasks
smoothly activated by bells; there is no counterpart of TPIK 2 (the arm
re-solved against the measured vehicle velocity): pink solves once per cycle
where the KCL solves twice. The timed pink cycle is ``Configuration.update``
(Pinocchio joint Jacobians and frame placements) then ``solve_ik``.
"""

from __future__ import annotations

import math

import numpy as np
import pinocchio as pin

from kcl.actions import ActionSet
from kcl.controller import ControllerConfig, MeasuredState
from kcl.model import UvmsModel
from kcl.rotations import rpy_to_matrix

_LWA = pin.ReferenceFrame.LOCAL_WORLD_ALIGNED


def _cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Row-wise cross products of two (k, 3) arrays (np.cross costs ~10 us of checks)."""
    out = np.empty_like(a)
    out[:, 0] = a[:, 1] * b[:, 2] - a[:, 2] * b[:, 1]
    out[:, 1] = a[:, 2] * b[:, 0] - a[:, 0] * b[:, 2]
    out[:, 2] = a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0]
    return out


def _barrier_base():
    from pink.barriers import Barrier

    return Barrier


def make_barriers(
    model: UvmsModel, ff: pin.Model, actions: ActionSet, camera_target: np.ndarray, altitude: list[float]
) -> list:
    """The grasp action's inequality tasks (other than joint limits) as pink
    barriers (h >= 0, Jacobians in pink's velocity order: base then joints).
    ``altitude``: a one-element list the caller updates every cycle (m)."""
    Barrier = _barrier_base()
    tasks = actions.tasks
    fid = {role: ff.getFrameId(model.frames[role]) for role in ("tool", "stereo_camera", "elbow")}
    nv = ff.nv
    l = model.n_joints
    upper = np.triu(np.ones((l, l)))  # joint i at or above joint j (serial chain)
    lower = np.tril(np.ones((l, l)), -1)  # joint i below joint j

    class ManipulabilityBarrier(Barrier):
        """h = mu(q) - mu_min, mu of the arm-only tool Jacobian (MARIS eq. 14)."""

        def __init__(self) -> None:
            super().__init__(dim=1, gain=1.0)
            self.mu_min = tasks["manipulability"].params["mu_min"]

        def _mu(self, configuration):
            J = pin.getFrameJacobian(configuration.model, configuration.data, fid["tool"], _LWA)[:, 6:]
            JJt = J @ J.T
            return math.sqrt(max(float(np.linalg.det(JJt)), 0.0)), J, JJt

        def compute_barrier(self, configuration) -> np.ndarray:
            return np.array([self._mu(configuration)[0] - self.mu_min])

        def compute_jacobian(self, configuration) -> np.ndarray:
            mu, J, JJt = self._mu(configuration)
            # dJ_j/dq_i = [w_i x v_j; w_i x w_j] for i <= j (serial chain), [w_j x v_i; 0] for i > j;
            # dmu/dq_i = mu <K, dJ/dq_i>, K = (J J^T)^-1 J, regrouped as triple products
            K = np.linalg.solve(JJt, J)
            v, w, Kv, Kw = J[:3].T, J[3:].T, K[:3].T, K[3:].T  # (l, 3)
            c = _cross(np.concatenate((v, w, Kv)), np.concatenate((Kv, Kw, w)))
            l = v.shape[0]
            t_upper = w @ (c[:l] + c[l : 2 * l]).T  # [i, j] = w_i . (v_j x Kv_j + w_j x Kw_j)
            t_lower = v @ c[2 * l :].T  # [i, j] = v_i . (Kv_j x w_j)
            out = np.zeros((1, nv))
            out[0, 6:] = mu * (upper * t_upper + lower * t_lower).sum(axis=1)
            return out

    class OcclusionBarrier(Barrier):
        """h = d - min_distance, d = distance of the elbow to the camera's line of sight."""

        def __init__(self) -> None:
            super().__init__(dim=1, gain=1.0)
            self.d_min = tasks["elbow_occlusion"].params["min_distance"]

        def _geometry(self, configuration):
            data = configuration.data
            o = data.oMf[fid["stereo_camera"]].translation
            b = camera_target - o
            nb = float(np.linalg.norm(b))
            u = b / nb
            s = data.oMf[fid["elbow"]].translation - o
            su = float(s @ u)
            r = s - su * u
            return r, float(np.linalg.norm(r)), 1.0 - su / nb

        def compute_barrier(self, configuration) -> np.ndarray:
            return np.array([self._geometry(configuration)[1] - self.d_min])

        def compute_jacobian(self, configuration) -> np.ndarray:
            r, d, k = self._geometry(configuration)
            m, data = configuration.model, configuration.data
            Je = pin.getFrameJacobian(m, data, fid["elbow"], _LWA)[:3]
            Jc = pin.getFrameJacobian(m, data, fid["stereo_camera"], _LWA)[:3]
            return ((r / d) @ (Je - k * Jc))[None, :]

    class CameraBarrier(Barrier):
        """h = max_angle - angle between the optical axis and the line of sight to the target."""

        def __init__(self) -> None:
            super().__init__(dim=1, gain=1.0)
            self.max_angle = tasks["camera_centering"].params["max_angle"]

        def _geometry(self, configuration):
            M = configuration.data.oMf[fid["stereo_camera"]]
            a = M.rotation[:, 2]
            b = camera_target - M.translation
            nb = float(np.linalg.norm(b))
            c = min(1.0, max(-1.0, float(a @ b) / nb))
            return a, b, nb, c, math.acos(c)

        def compute_barrier(self, configuration) -> np.ndarray:
            return np.array([self.max_angle - self._geometry(configuration)[4]])

        def compute_jacobian(self, configuration) -> np.ndarray:
            a, b, nb, c, angle = self._geometry(configuration)
            J = pin.getFrameJacobian(configuration.model, configuration.data, fid["stereo_camera"], _LWA)
            s = max(math.sin(angle), 1e-9)
            d_angle = ((a / nb - c * b / nb**2) @ J[:3] - (_cross(a[None, :], b[None, :])[0] / nb) @ J[3:]) / s
            return -d_angle[None, :]

    class AltitudeBarrier(Barrier):
        """h = altitude - min_altitude; the altitude rate is minus the world-down velocity."""

        def __init__(self) -> None:
            super().__init__(dim=1, gain=1.0)
            self.min_altitude = tasks["altitude"].params["min_altitude"]

        def compute_barrier(self, configuration) -> np.ndarray:
            return np.array([altitude[0] - self.min_altitude])

        def compute_jacobian(self, configuration) -> np.ndarray:
            R = configuration.data.oMf[1].rotation  # the vehicle (root) frame
            out = np.zeros((1, nv))
            out[0, :3] = -R[2]
            return out

    class AttitudeBarrier(Barrier):
        """h = max_angle - |roll|, max_angle - |pitch| (Euler-rate rows on the body rates)."""

        def __init__(self) -> None:
            super().__init__(dim=2, gain=1.0)
            self.max_angle = tasks["horizontal_attitude"].params["max_angle"]

        def _rpy(self, configuration):
            return pin.rpy.matrixToRpy(configuration.data.oMf[1].rotation)

        def compute_barrier(self, configuration) -> np.ndarray:
            roll, pitch, _ = self._rpy(configuration)
            return np.array([self.max_angle - abs(roll), self.max_angle - abs(pitch)])

        def compute_jacobian(self, configuration) -> np.ndarray:
            roll, pitch, _ = self._rpy(configuration)
            sr, cr, tp = math.sin(roll), math.cos(roll), math.tan(pitch)
            out = np.zeros((2, nv))
            out[0, 3:6] = (-math.copysign(1.0, roll)) * np.array([1.0, sr * tp, cr * tp])
            out[1, 3:6] = (-math.copysign(1.0, pitch)) * np.array([0.0, cr, -sr])
            return out

    return [ManipulabilityBarrier(), OcclusionBarrier(), CameraBarrier(), AltitudeBarrier(), AttitudeBarrier()]


class PinkGrasp:
    """One pink configuration and the grasp stack; :meth:`cycle` is what is timed."""

    def __init__(
        self,
        model: UvmsModel,
        actions: ActionSet,
        tool_goal: np.ndarray,
        camera_target: np.ndarray,
        *,
        full: bool,
        dt: float = 0.01,
    ):
        import pink
        from pink.limits import ConfigurationLimit, VelocityLimit
        from pink.tasks import FrameTask, PostureTask

        self._pink = pink
        ff = pin.buildModelFromUrdf(model.urdf_path, pin.JointModelFreeFlyer())
        margin = actions.tasks["joint_limits"].params["margin"]
        ff.lowerPositionLimit[7:] = model.joint_lower + margin
        ff.upperPositionLimit[7:] = model.joint_upper - margin
        ff.velocityLimit[:6] = ControllerConfig().vehicle_velocity_limit
        self.model = ff
        self.dt = dt
        self.altitude = [1.0]
        self.config = pink.Configuration(
            ff, ff.createData(), self.to_pin_q(np.array(actions.postures["grasp_ready"], dtype=float), np.zeros(6))
        )
        tool = FrameTask(model.frames["tool"], position_cost=1.0, orientation_cost=1.0)
        tool.set_target(pin.SE3(tool_goal[:3, :3], tool_goal[:3, 3]))
        posture = PostureTask(cost=1e-2)
        target = self.config.q.copy()
        target[7:] = actions.postures["grasp_ready"]
        posture.set_target(target)
        self.tasks = [tool, posture]
        self.limits = [ConfigurationLimit(ff), VelocityLimit(ff)]
        self.barriers = make_barriers(model, ff, actions, camera_target, self.altitude) if full else []
        if not full:  # only the horizontal attitude (the inequality task active in the typical states)
            self.barriers = [
                b
                for b in make_barriers(model, ff, actions, camera_target, self.altitude)
                if type(b).__name__ == "AttitudeBarrier"
            ]
        self.damping = 1e-4

    @staticmethod
    def to_pin_q(q: np.ndarray, eta: np.ndarray) -> np.ndarray:
        quat = pin.Quaternion(rpy_to_matrix(*eta[3:]))
        return np.concatenate([eta[:3], quat.coeffs(), q])

    def shape(self) -> tuple[int, int, int]:
        """(cost rows, constraint rows, barrier rows) of the QP at the current configuration."""
        cost = sum(t.compute_jacobian(self.config).shape[0] for t in self.tasks)
        ineq = sum(lim.compute_qp_inequalities(self.config, self.dt)[0].shape[0] for lim in self.limits)
        bars = sum(b.dim for b in self.barriers)
        return cost, ineq + bars, bars

    def cycle(self, q_pin: np.ndarray, altitude: float) -> np.ndarray:
        """One control cycle: update the kinematics, build and solve the QP (13 velocities)."""
        self.altitude[0] = altitude
        self.config.update(q_pin)
        return self._pink.solve_ik(
            self.config,
            self.tasks,
            self.dt,
            solver="daqp",
            damping=self.damping,
            limits=self.limits,
            barriers=self.barriers,
            safety_break=False,
        )

    def build_and_solve(self, q_pin: np.ndarray, altitude: float) -> tuple[float, float]:
        """:meth:`cycle` in two timed parts: (update + QP build, QP solve) in seconds."""
        import time

        import qpsolvers
        from pink.solve_ik import build_ik

        t0 = time.perf_counter()
        self.altitude[0] = altitude
        self.config.update(q_pin)
        problem = build_ik(self.config, self.tasks, self.dt, self.damping, self.limits, self.barriers)
        t1 = time.perf_counter()
        result = qpsolvers.solve_problem(problem, solver="daqp")
        t2 = time.perf_counter()
        if not result.found:
            raise RuntimeError("pink's QP has no solution at this state")
        return t1 - t0, t2 - t1


def pink_inputs(states: list[MeasuredState]) -> list[tuple[np.ndarray, float]]:
    """Pink configuration vectors (free-flyer position, quaternion, joints) and altitudes."""
    return [(PinkGrasp.to_pin_q(np.asarray(s.q), np.asarray(s.eta)), float(s.altitude or 0.0)) for s in states]
