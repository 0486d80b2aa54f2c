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
from dataclasses import dataclass

import numpy as np
import pinocchio as pin

from kcl.rotations import rpy_to_quaternion

MAP_FRAME = "map"
WORLD_FRAME = "world"
#: map (ENU, z up) -> world (NED): x_map = y_world, y_map = x_world, z_map = -z_world.
MAP_TO_WORLD_QUAT = (math.sqrt(0.5), math.sqrt(0.5), 0.0, 0.0)


@dataclass(frozen=True)
class Transform:
    """Pose of ``child`` in ``parent``: translation (m) and quaternion (x, y, z, w)."""

    parent: str
    child: str
    translation: tuple[float, float, float]
    rotation: tuple[float, float, float, float]


def pose_to_transform(parent: str, child: str, T: np.ndarray) -> Transform:
    """A 4x4 homogeneous pose of ``child`` in ``parent`` as a :class:`Transform`."""
    T = np.asarray(T, dtype=float)
    q = pin.Quaternion(T[:3, :3].copy())
    q.normalize()
    return Transform(parent, child, (float(T[0, 3]), float(T[1, 3]), float(T[2, 3])),
                     (float(q.x), float(q.y), float(q.z), float(q.w)))


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
    parents before children."""

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

    def transforms(self, q: np.ndarray) -> list[Transform]:
        """Parent -> child transform of every URDF edge at joint angles ``q`` (rad)."""
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
