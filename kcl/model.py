"""Kinematic model of the vehicle-manipulator system (UVMS), built with Pinocchio.

The URDF describes the vehicle body (its root link is the vehicle frame, FRD,
origin at the vehicle reference point) and the arm. Two Pinocchio models are
built from it: the arm on a fixed base (single frame poses in the vehicle
frame, joint limits) and its free-flyer twin, whose root joint is the vehicle's
6-DOF floating base and whose numbers the compiled serial chain takes
(:meth:`UvmsModel.chain`, :mod:`kcl.kin_frames`). Our system velocity is
``ydot = [qdot; v]`` (joints first) with ``v = [u v w p q r]`` the body
velocity in the vehicle frame. Tests check every Jacobian against finite
differences of poses integrated with :func:`kcl.rotations.integrate_pose`, and
the chain against Pinocchio's own Jacobians.

Use:

* :meth:`UvmsModel.load` (``urdf=None`` is the shipped default,
  ``kcl/data/r2_uma.urdf``), ``frames`` maps roles (``tool``, ``stereo_camera``,
  ``palm_camera``, ``elbow``) to URDF link/frame names.
* :meth:`UvmsModel.frame_pose_vehicle` / :meth:`UvmsModel.frame_pose_world`:
  cheap single poses (the simulator calls them every step).
* :meth:`UvmsModel.kinematics`: a :class:`Kinematics` snapshot (frames and
  Jacobians at one state, the numbers the controller's tasks read).

A model object owns one Pinocchio ``Data`` and the chain's scratch buffers: it
is not thread-safe; load one per thread (loading takes a few milliseconds).
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path

import numpy as np
import pinocchio as pin

from kcl.kin_frames import chain_buffers, frames_world
from kcl.kin_kernel import configure
from kcl.manipulability import manipulability_gradient
from kcl.rotations import homogeneous, rpy_to_matrix
from maris_common.yamlsrc import ConfigError, ConfigIssue, Mark, suggest

DATA_DIR = Path(__file__).resolve().parent / "data"
DEFAULT_URDF = DATA_DIR / "r2_uma.urdf"

#: Frame roles used by the tasks, mapped to the frame names of the default URDF.
DEFAULT_FRAMES: dict[str, str] = {
    "tool": "tool",
    "stereo_camera": "stereo_camera",
    "palm_camera": "palm_camera",
    "elbow": "elbow",
}


def _urdf_error(path: str, message: str) -> ConfigError:
    return ConfigError([ConfigIssue(Mark(path, 1, 1), ("urdf",), message)])


def pose_in_world(vTf: np.ndarray, eta: np.ndarray) -> np.ndarray:
    """Pose ``wTf`` (4x4) in the world (NED) of a frame at ``vTf`` (4x4) in the
    vehicle frame, vehicle at ``eta = [x, y, z, roll, pitch, yaw]`` (m, rad)."""
    out = np.empty((4, 4))
    R = rpy_to_matrix(eta[3], eta[4], eta[5])
    out[:3, :3] = R @ vTf[:3, :3]
    out[:3, 3] = R @ vTf[:3, 3] + np.asarray(eta[:3], dtype=float)
    out[3] = (0.0, 0.0, 0.0, 1.0)
    return out


class UvmsModel:
    """A vehicle (6-DOF floating base) carrying an arm of ``n_joints`` joints.

    Attributes: ``n_joints`` (l), ``n`` (l + 6), ``joint_names``,
    ``joint_lower`` / ``joint_upper`` (rad), ``joint_velocity_limit`` (rad/s),
    ``frames`` (role -> URDF frame name), ``urdf_path``.
    """

    def __init__(self, pin_model: pin.Model, frames: Mapping[str, str], urdf_path: str):
        self.pin_model = pin_model
        self.pin_data = pin_model.createData()
        self.urdf_path = urdf_path
        self.frames: dict[str, str] = dict(frames)
        self.n_joints: int = pin_model.nv
        self.n: int = self.n_joints + 6
        self.joint_names: tuple[str, ...] = tuple(pin_model.names[1:])
        self.joint_lower = np.array(pin_model.lowerPositionLimit, dtype=float)
        self.joint_upper = np.array(pin_model.upperPositionLimit, dtype=float)
        self.joint_velocity_limit = np.array(pin_model.velocityLimit, dtype=float)
        self._frame_ids: dict[str, int] = {}
        for role, name in self.frames.items():
            self._frame_ids[role] = pin_model.getFrameId(name)
        # joint i (0-based, arm index) is a strict ancestor of joint j
        l = self.n_joints
        self._ancestor = np.zeros((l, l), dtype=bool)
        for j in range(1, pin_model.njoints):
            parent = pin_model.parents[j]
            while parent > 0:
                self._ancestor[parent - 1, j - 1] = True
                parent = pin_model.parents[parent]
        # free-flyer twin whose numbers the compiled chain takes (same URDF, root joint added)
        self.ff_model = pin.buildModelFromUrdf(urdf_path, pin.JointModelFreeFlyer())
        self._ff_ids: dict[str, int] = {}
        self._ff_id_lists: dict[tuple[str, ...], tuple[int, ...]] = {}
        self._chains: dict[tuple[str, ...], tuple[np.ndarray, np.ndarray]] = {}
        self._fk_q: np.ndarray | None = None
        self._masks: dict[str, tuple[np.ndarray, np.ndarray]] = {}

    # ------------------------------------------------------------------ loading

    @classmethod
    def load(cls, urdf: str | Path | None = None, frames: Mapping[str, str] | None = None) -> UvmsModel:
        """Load a UVMS from a URDF (``None``: the shipped R2 + UMA-like arm).

        ``frames`` overrides role -> frame-name entries (roles missing from it keep
        the defaults). Every movable URDF joint must be a one-DOF arm joint
        (revolute or prismatic, with limits). Problems raise :class:`ConfigError`.
        """
        path = Path(urdf) if urdf is not None else DEFAULT_URDF
        if not path.is_file():
            raise _urdf_error(str(path), "URDF file not found")
        try:
            model = pin.buildModelFromUrdf(str(path))
        except Exception as exc:  # Pinocchio raises plain ValueError/RuntimeError
            raise _urdf_error(str(path), f"cannot build a model from this URDF: {exc}") from None
        issues: list[ConfigIssue] = []
        if model.nq != model.nv:
            issues.append(
                ConfigIssue(
                    Mark(str(path), 1, 1),
                    ("urdf",),
                    "only one-DOF joints are supported (no continuous/floating/planar joints)",
                )
            )
        if model.nv == 0:
            issues.append(ConfigIssue(Mark(str(path), 1, 1), ("urdf",), "the URDF has no movable arm joint"))
        roles = dict(DEFAULT_FRAMES)
        roles.update(frames or {})
        names = [f.name for f in model.frames]
        for role, name in roles.items():
            if not model.existFrame(name):
                issues.append(
                    ConfigIssue(
                        Mark(str(path), 1, 1), ("frames", role), f"frame `{name}` not in the URDF{suggest(name, names)}"
                    )
                )
        lo, hi = np.asarray(model.lowerPositionLimit), np.asarray(model.upperPositionLimit)
        if not issues and (not np.all(np.isfinite(lo)) or not np.all(np.isfinite(hi)) or np.any(hi <= lo)):
            issues.append(
                ConfigIssue(
                    Mark(str(path), 1, 1), ("urdf",), "every arm joint needs finite lower < upper position limits"
                )
            )
        if not issues and np.any(np.asarray(model.velocityLimit) <= 0):
            issues.append(
                ConfigIssue(Mark(str(path), 1, 1), ("urdf",), "every arm joint needs a positive velocity limit")
            )
        if issues:
            raise ConfigError(issues)
        return cls(model, roles, str(path))

    # ------------------------------------------------------------------ frames

    def frame_id(self, frame: str) -> int:
        """Pinocchio frame index of a role (``tool``, ...) or of a URDF frame name."""
        fid = self._frame_ids.get(frame)
        if fid is None:
            if not self.pin_model.existFrame(frame):
                raise KeyError(f"unknown frame `{frame}`; roles: {', '.join(self.frames)}")
            fid = self._frame_ids[frame] = self.pin_model.getFrameId(frame)
        return fid

    def ff_frame_id(self, frame: str) -> int:
        """Frame index in the free-flyer twin of a role or URDF frame name."""
        fid = self._ff_ids.get(frame)
        if fid is None:
            name = self.pin_model.frames[self.frame_id(frame)].name
            fid = self._ff_ids[frame] = self.ff_model.getFrameId(name)
        return fid

    def ff_frame_ids(self, frames: list[str] | tuple[str, ...]) -> tuple[int, ...]:
        """:meth:`ff_frame_id` of each of ``frames`` (cached per list content)."""
        key = frames if frames.__class__ is tuple else tuple(frames)
        ids = self._ff_id_lists.get(key)
        if ids is None:
            ids = self._ff_id_lists[key] = tuple(self.ff_frame_id(f) for f in frames)
        return ids

    def chain(self, frames: tuple[str, ...]) -> tuple[np.ndarray, np.ndarray]:
        """The buffers of :func:`kcl.kin_frames.frames_world` for ``frames``
        (roles or URDF names; cached per tuple)."""
        try:
            return self._chains[frames]
        except KeyError:
            bufs = self._chains[frames] = chain_buffers(self.ff_model, self.ff_frame_ids(frames))
            return bufs

    def _forward(self, q: np.ndarray) -> None:
        """Forward kinematics for ``q`` unless it is the last configuration seen."""
        if self._fk_q is not None and np.array_equal(q, self._fk_q):
            return
        pin.forwardKinematics(self.pin_model, self.pin_data, q)
        self._fk_q = np.array(q, dtype=float)

    def frame_pose_vehicle(self, q: np.ndarray, frame: str) -> np.ndarray:
        """Pose ``vTf`` (4x4) of ``frame`` (role or URDF name) in the vehicle frame."""
        q = np.asarray(q, dtype=float)
        self._forward(q)
        return pin.updateFramePlacement(self.pin_model, self.pin_data, self.frame_id(frame)).homogeneous

    def frame_pose_world(self, q: np.ndarray, eta: np.ndarray, frame: str) -> np.ndarray:
        """Pose ``wTf`` (4x4) in the world (NED), vehicle at ``eta = [x,y,z,roll,pitch,yaw]``."""
        return pose_in_world(self.frame_pose_vehicle(q, frame), eta)

    def hessian_masks(self, frame: str) -> tuple[np.ndarray, np.ndarray]:
        """Masks [i, j] over joints moving ``frame``: i strictly above j; i at or below j."""
        masks = self._masks.get(frame)
        if masks is None:
            parent = self.pin_model.frames[self.frame_id(frame)].parentJoint
            support = np.zeros(self.n_joints, dtype=bool)
            for j in self.pin_model.supports[parent]:
                if j > 0:
                    support[j - 1] = True
            both = support[:, None] & support[None, :]
            above = (self._ancestor & both).astype(float)
            at_or_below = ((np.eye(self.n_joints, dtype=bool) | self._ancestor.T) & both).astype(float)
            masks = self._masks[frame] = (above, at_or_below)
        return masks

    def neutral(self) -> np.ndarray:
        """Joint configuration in the middle of the limits (rad)."""
        return 0.5 * (self.joint_lower + self.joint_upper)

    def kinematics(self, q: np.ndarray, eta: np.ndarray) -> Kinematics:
        """Snapshot of all frames and Jacobians at ``(q, eta)``; see :class:`Kinematics`."""
        return Kinematics(self, q, eta)

    def manipulability(self, q: np.ndarray, frame: str = "tool") -> tuple[float, np.ndarray]:
        """``(mu, dmu/dq)`` of the arm at ``frame`` (see :meth:`Kinematics.manipulability`)."""
        return self.kinematics(q, np.zeros(6)).manipulability(frame)


class Kinematics:
    """Kinematics of the UVMS at one configuration ``(q, eta)``: the frames the
    controller's tasks read, from the compiled serial chain
    (:func:`kcl.kin_frames.frames_world`).

    Jacobians map ``ydot = [qdot; v]`` (l + 6) to ``[linear; angular]`` velocity
    of a frame (its origin's velocity, m/s, and angular velocity, rad/s) relative
    to the world; ``*_world`` express them in world axes, ``*_vehicle`` in vehicle
    axes. Results are cached per frame; returned arrays must not be modified.
    """

    def __init__(self, model: UvmsModel, q: np.ndarray, eta: np.ndarray):
        self.model = model
        self.q = q = np.array(q, dtype=float)
        self.eta = eta = np.array(eta, dtype=float)
        self.l = l = model.n_joints
        self.n = model.n
        if eta.shape != (6,) or q.shape != (l,):
            raise ValueError(f"Kinematics: q must be ({l},) and eta (6,), got {q.shape} and {eta.shape}")
        self.wRv = np.empty((3, 3))
        configure(q, eta, self.wRv, np.empty(7 + l))
        self._world: dict[str, tuple[np.ndarray, np.ndarray]] = {}
        self._vehicle: dict[str, tuple[np.ndarray, np.ndarray]] = {}
        self._mu: dict[str, tuple[float, np.ndarray]] = {}

    @property
    def wTv(self) -> np.ndarray:
        """Vehicle pose in the world (4x4)."""
        return homogeneous(self.wRv, self.eta[:3])

    def _frame_world(self, frame: str) -> tuple[np.ndarray, np.ndarray]:
        """``(wTf, J)`` of ``frame``: world pose (4x4) and world Jacobian (6 x n)."""
        out = self._world.get(frame)
        if out is None:
            kin_i, kin_f = self.model.chain((frame,))
            P, Jw = np.empty((1, 4, 4)), np.empty((1, 6, self.n))
            frames_world(self.q, self.eta, self.wRv, kin_i, kin_f, P, Jw)
            out = self._world[frame] = (P[0], Jw[0])
        return out

    def _frame_vehicle(self, frame: str) -> tuple[np.ndarray, np.ndarray]:
        """``(vTf, J)`` of ``frame``: pose (4x4) and Jacobian (6 x n) in vehicle axes."""
        out = self._vehicle.get(frame)
        if out is None:
            wT, Jw = self._frame_world(frame)
            vT = np.eye(4)
            vT[:3, :3] = self.wRv.T @ wT[:3, :3]
            vT[:3, 3] = self.wRv.T @ (wT[:3, 3] - self.eta[:3])
            Jv = np.matmul(self.wRv.T, Jw.reshape(2, 3, self.n)).reshape(6, self.n)
            out = self._vehicle[frame] = (vT, Jv)
        return out

    def pose_world(self, frame: str) -> np.ndarray:
        """``wTf`` (4x4), world NED."""
        return self._frame_world(frame)[0]

    def pose_vehicle(self, frame: str) -> np.ndarray:
        """``vTf`` (4x4)."""
        return self._frame_vehicle(frame)[0]

    def position_world(self, frame: str) -> np.ndarray:
        """Origin of ``frame`` in the world (3,), m."""
        return self.pose_world(frame)[:3, 3]

    def jacobian_world(self, frame: str) -> np.ndarray:
        """Full Jacobian (6 x n) w.r.t. ``[qdot; v]``, expressed in world axes."""
        return self._frame_world(frame)[1]

    def jacobian_vehicle(self, frame: str) -> np.ndarray:
        """Full Jacobian (6 x n) w.r.t. ``[qdot; v]``, expressed in vehicle axes."""
        return self._frame_vehicle(frame)[1]

    def arm_jacobian(self, frame: str = "tool") -> np.ndarray:
        """Arm-only Jacobian (6 x l) of ``frame``, vehicle axes (vehicle held still)."""
        return self.jacobian_vehicle(frame)[:, : self.l]

    def manipulability(self, frame: str = "tool") -> tuple[float, np.ndarray]:
        """Arm manipulability ``mu = sqrt(det(J J^T))`` of the arm-only Jacobian of
        ``frame`` (6 x l, mixed m and rad units) and its gradient ``dmu/dq`` (l,).

        Computed by :func:`kcl.manipulability.manipulability_gradient` (analytic;
        ``J^T J`` for l < 6), the code of the manipulability task's kernel.
        """
        cached = self._mu.get(frame)
        if cached is not None:
            return cached
        above, at_or_below = self.model.hessian_masks(frame)
        grad = np.empty(self.l)
        Ja = np.ascontiguousarray(self.jacobian_world(frame)[:, : self.l])
        out = (float(manipulability_gradient(Ja, above, at_or_below, grad)), grad)
        self._mu[frame] = out
        return out
