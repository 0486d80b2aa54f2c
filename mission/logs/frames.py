"""The frame tree of a UVMS for the 3D view: ``map -> world -> base_link -> links``.

* ``map``: a z-up (ENU) root for viewers, whose 3D panels treat +z as up;
  ``world`` is the project's world frame (NED, :mod:`hal.interfaces`), so
  ``map -> world`` is the fixed 180 deg turn about the (1, 1, 0) axis.
* ``vehicle_level``: child of ``map`` at the vehicle's position, with the
  ``map`` axes (z up): the frame a 3D view follows to keep the vehicle in the
  middle with the surface up (``base_link`` is FRD, its z points down).
* ``base_link`` (the URDF root link): the vehicle frame (FRD) at the vehicle
  pose ``eta = [x, y, z, roll, pitch, yaw]`` in ``world``.
* every other URDF link, child of the link its URDF joint hangs from, at the
  arm configuration ``q`` (rad), from :class:`kcl.model.UvmsModel` (Pinocchio).

:class:`LinkTree` computes the parent -> child transforms (translation m,
quaternion x y z w) for one ``(eta, q)``; :mod:`mission.logs.wellknown` turns
them into ``foxglove.FrameTransforms``.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np
import pinocchio as pin

from kcl.rotations import rpy_to_quaternion

MAP_FRAME = "map"
WORLD_FRAME = "world"
#: map (ENU, z up) -> world (NED): x_map = y_world, y_map = x_world, z_map = -z_world.
MAP_TO_WORLD_QUAT = (math.sqrt(0.5), math.sqrt(0.5), 0.0, 0.0)


class Transform(NamedTuple):
    """Pose of ``child`` in ``parent``: translation (m) and quaternion (x, y, z, w).
    (A named tuple: a dozen or more are built per 3D-view sample, and a named tuple
    costs less to build than a frozen dataclass.)"""

    parent: str
    child: str
    translation: tuple[float, float, float]
    rotation: tuple[float, float, float, float]


def rotation_to_quaternion(rows: list) -> tuple[float, float, float, float] | None:
    """Unit quaternion (x, y, z, w) of the rotation matrix whose first three rows are
    ``rows`` (lists of floats; a 4x4 pose's ``tolist()`` will do), in plain floats.

    The conversion Eigen makes (and so ``pinocchio.Quaternion(R)``): from the trace
    when it is positive, else from the largest diagonal entry, then normalized; the
    same numbers within 4.5e-16, two units in the last place of 1.0
    (``tests/logs/test_frames.py``).
    It costs :func:`pose_to_transform` less than Pinocchio's quaternion would, and
    that runs for the goal, target, pipe and detection frames of every 3D-view sample.

    None when ``rows`` holds a non-finite number (the caller then uses Pinocchio);
    a finite matrix always converts (in the second branch the square root's
    argument is ``2 m_ii - trace + 1 >= 1``)."""
    (m00, m01, m02), (m10, m11, m12), (m20, m21, m22) = rows[0][:3], rows[1][:3], rows[2][:3]
    if not -math.inf < m00 + m01 + m02 + m10 + m11 + m12 + m20 + m21 + m22 < math.inf:
        return None  # a NaN or an infinity among them (or a sum that overflows)
    trace = m00 + m11 + m22
    if trace > 0.0:
        t = math.sqrt(trace + 1.0)
        w = 0.5 * t
        t = 0.5 / t
        x, y, z = (m21 - m12) * t, (m02 - m20) * t, (m10 - m01) * t
    else:
        m = ((m00, m01, m02), (m10, m11, m12), (m20, m21, m22))
        i = 1 if m11 > m00 else 0
        if m22 > m[i][i]:
            i = 2
        j = (i + 1) % 3
        k = (j + 1) % 3
        t = math.sqrt(m[i][i] - m[j][j] - m[k][k] + 1.0)
        c = [0.0, 0.0, 0.0]
        c[i] = 0.5 * t
        t = 0.5 / t
        w = (m[k][j] - m[j][k]) * t
        c[j] = (m[j][i] + m[i][j]) * t
        c[k] = (m[k][i] + m[i][k]) * t
        x, y, z = c
    n = math.sqrt(x * x + y * y + z * z + w * w)
    return (x / n, y / n, z / n, w / n)


def pose_to_transform(parent: str, child: str, T: np.ndarray) -> Transform:
    """A 4x4 homogeneous pose of ``child`` in ``parent`` as a :class:`Transform`."""
    rows = np.asarray(T, dtype=float).tolist()  # the array itself when it is already float
    quat = rotation_to_quaternion(rows)
    if quat is None:
        q = pin.Quaternion(np.asarray(rows, dtype=float)[:3, :3].copy())
        q.normalize()
        quat = (float(q.x), float(q.y), float(q.z), float(q.w))
    return Transform(parent, child, (float(rows[0][3]), float(rows[1][3]), float(rows[2][3])), quat)


def eta_to_transform(parent: str, child: str, eta: np.ndarray) -> Transform:
    """Vehicle pose ``eta = [x, y, z, roll, pitch, yaw]`` (m, rad) as a :class:`Transform`."""
    x, y, z, roll, pitch, yaw = (float(v) for v in eta)
    return Transform(parent, child, (x, y, z), rpy_to_quaternion(roll, pitch, yaw))


LEVEL_FRAME = "vehicle_level"


def map_transform() -> Transform:
    return Transform(MAP_FRAME, WORLD_FRAME, (0.0, 0.0, 0.0), MAP_TO_WORLD_QUAT)


def level_transform(position_ned: np.ndarray) -> Transform:
    """``map -> vehicle_level``: the vehicle position (world NED, m) with map axes."""
    x, y, z = (float(v) for v in position_ned[:3])
    return Transform(MAP_FRAME, LEVEL_FRAME, (y, x, -z), (0.0, 0.0, 0.0, 1.0))


class LinkTree:
    """The URDF links of a :class:`kcl.model.UvmsModel` as a parent/child tree.

    ``root`` is the URDF root link (the vehicle frame); ``edges`` lists
    ``(parent_link, child_link)`` for every URDF joint, fixed ones included,
    parents before children.

    :meth:`transforms` runs every 3D-view sample (10 Hz in a run), so it does not
    call Pinocchio: a fixed edge's transform is computed once; a revolute joint's
    (about its x, y or z axis, the child link's frame on the joint, as URDF makes
    it) is ``L * rotation(q_i)`` with the constant placement ``L`` (parent link ->
    joint): ``L``'s translation and a quaternion product, in plain floats
    (``tests/logs/test_frames.py`` checks it against Pinocchio's forward kinematics). Any other joint type falls back to Pinocchio
    for the whole tree."""

    def __init__(self, model) -> None:
        self.model = model
        pm = model.pin_model
        self._frame_ids: dict[str, int] = {}
        edges: list[tuple[str, str]] = []
        root = None
        for fid, frame in enumerate(pm.frames):
            if frame.type != pin.FrameType.BODY:
                continue
            self._frame_ids[frame.name] = fid
            joint_frame = pm.frames[frame.parentFrame]
            if joint_frame.name == "universe" or frame.parentFrame == 0:
                root = frame.name if root is None else root
                continue
            parent = pm.frames[joint_frame.parentFrame]
            if parent.type == pin.FrameType.BODY:
                edges.append((parent.name, frame.name))
        if root is None:
            raise ValueError("the model has no root link")
        self.root: str = root
        self.edges: list[tuple[str, str]] = edges
        self.links: list[str] = [root] + [c for _, c in edges]
        self._data = pm.createData()
        self._edge_ids = [(p, c, self._frame_ids[p], self._frame_ids[c]) for p, c in edges]
        self._plan = _edge_plan(pm, self._edge_ids)

    def transforms(self, q: np.ndarray) -> list[Transform]:
        """Parent -> child transform of every URDF edge at joint angles ``q`` (rad)."""
        plan = self._plan
        if plan is None:
            return self.transforms_pinocchio(q)
        qs = q.tolist() if type(q) is np.ndarray else [float(v) for v in q]
        sin, cos = math.sin, math.cos
        out = []
        for edge in plan:
            if type(edge) is Transform:  # fixed
                out.append(edge)
                continue
            parent, child, i, axis, t, lq = edge
            h = 0.5 * qs[i]
            s = sin(h)
            # quaternion (x, y, z, w) of L.R * rotation(q_i) about the joint axis
            x, y, z, w = _qmul(
                lq,
                (s, 0.0, 0.0, cos(h)) if axis == 0 else (0.0, s, 0.0, cos(h)) if axis == 1 else (0.0, 0.0, s, cos(h)),
            )
            out.append(Transform(parent, child, t, (x, y, z, w)))
        return out

    def transforms_pinocchio(self, q: np.ndarray) -> list[Transform]:
        """:meth:`transforms` from Pinocchio's forward kinematics (any joint type)."""
        pm, data = self.model.pin_model, self._data
        pin.forwardKinematics(pm, data, np.asarray(q, dtype=float))
        pin.updateFramePlacements(pm, data)
        oMf, xyzquat = data.oMf, pin.SE3ToXYZQUAT
        out = []
        for parent, child, ip, ic in self._edge_ids:
            x = xyzquat(oMf[ip].actInv(oMf[ic])).tolist()
            out.append(Transform(parent, child, (x[0], x[1], x[2]), (x[3], x[4], x[5], x[6])))
        return out

    def vehicle_poses(self, q: np.ndarray) -> dict[str, np.ndarray]:
        """4x4 pose of every link in the vehicle (root) frame at ``q``."""
        pm, data = self.model.pin_model, self._data
        pin.forwardKinematics(pm, data, np.asarray(q, dtype=float))
        pin.updateFramePlacements(pm, data)
        return {name: data.oMf[fid].homogeneous.copy() for name, fid in self._frame_ids.items()}


#: Pinocchio's revolute joints about a principal axis -> axis index (x 0, y 1, z 2).
_AXES = {"JointModelRX": 0, "JointModelRY": 1, "JointModelRZ": 2}


def _qmul(a: tuple, b: tuple) -> tuple[float, float, float, float]:
    """Hamilton product of quaternions ``a * b``, both (x, y, z, w)."""
    ax, ay, az, aw = a
    bx, by, bz, bw = b
    return (
        aw * bx + ax * bw + ay * bz - az * by,
        aw * by - ax * bz + ay * bw + az * bx,
        aw * bz + ax * by - ay * bx + az * bw,
        aw * bw - ax * bx - ay * by - az * bz,
    )


def _xyzquat(M: pin.SE3) -> tuple[tuple[float, float, float], tuple[float, float, float, float]]:
    x = pin.SE3ToXYZQUAT(M).tolist()
    return (x[0], x[1], x[2]), (x[3], x[4], x[5], x[6])


def _edge_plan(pm: pin.Model, edge_ids: list[tuple[str, str, int, int]]) -> list | None:
    """Per edge, a constant :class:`Transform` (the child link rigidly on the parent's
    joint) or ``(parent, child, q index, axis, L.t, L.q)`` for a child link whose frame
    is its revolute joint's (about a principal axis), that joint's parent being the
    parent link's; None when an edge is neither (the caller uses Pinocchio)."""
    plan: list = []
    for parent, child, ip, ic in edge_ids:
        fp, fc = pm.frames[ip], pm.frames[ic]
        jp, jc = fp.parentJoint, fc.parentJoint
        if jc == jp:
            t, quat = _xyzquat(fp.placement.actInv(fc.placement))
            plan.append(Transform(parent, child, t, quat))
            continue
        axis = _AXES.get(pm.joints[jc].shortname())
        if axis is None or pm.parents[jc] != jp or pm.nqs[jc] != 1 or not fc.placement.isIdentity():
            return None
        lt, lq = _xyzquat(fp.placement.actInv(pm.jointPlacements[jc]))
        plan.append((parent, child, int(pm.idx_qs[jc]), axis, lt, lq))
    return plan
