"""The pool and the pipe (world frame NED, metres).

The pool is a box: surface at z = 0, flat floor at z = depth. The pipe is a
rigid cylinder. Its *centre frame* has x along the axis; while it lies in the
pool its z axis points down (world), so the frame is a pure yaw rotation. The
*grasp frame* (what vision reports, what the tool must reach) is the centre
frame shifted by ``grasp_offset`` along the axis. While the gripper holds the
pipe, the pipe is rigidly attached to the tool frame.
"""

from __future__ import annotations

import numpy as np

from .geometry import norm, rotation_rpy, rpy_from_rotation

#: Half height of an R2-class hull (m): the vehicle reference point stays this far off the floor
#: (the default; a scenario's hull gives its own: half of ``vehicle.size_m``'s height).
HULL_HALF_HEIGHT_M = 0.5


class Pipe:
    """Pose and size of the target pipe; ``world_T_centre`` is a (4, 4) pose."""

    def __init__(self, x: float, y: float, z: float, yaw: float, length: float, radius: float, grasp_offset: float):
        self.length = length
        self.radius = radius
        self.grasp_offset = grasp_offset
        self.world_T_centre = np.eye(4)
        self.world_T_centre[:3, :3] = rotation_rpy(0.0, 0.0, yaw)
        self.world_T_centre[:3, 3] = (x, y, z)
        self._centre_T_grasp = np.eye(4)
        self._centre_T_grasp[0, 3] = grasp_offset
        # the grasp pose and the pose dict of the last world_T_centre (its bytes): the pipe
        # rests most of the time, and both are asked for at every image and truth sample
        self._key: bytes | None = None
        self._grasp = np.eye(4)
        self._dict: dict = {}

    @property
    def axis(self) -> np.ndarray:
        """Unit axis direction (3,), world."""
        return self.world_T_centre[:3, 0]

    def grasp_pose(self) -> np.ndarray:
        """World pose (4, 4) of the grasp frame (a new array)."""
        self._refresh()
        return self._grasp.copy()

    def _refresh(self) -> None:
        """The grasp pose and the pose dict of the current ``world_T_centre`` (cached:
        recomputed, by the same arithmetic, when it changed)."""
        key = self.world_T_centre.tobytes()
        if key != self._key:
            g = self.world_T_centre @ self._centre_T_grasp
            self._grasp = g
            self._dict = {
                "centre_position": self.world_T_centre[:3, 3].tolist(),
                "centre_rpy": list(rpy_from_rotation(self.world_T_centre[:3, :3])),
                "grasp_position": g[:3, 3].tolist(),
                "grasp_rpy": list(rpy_from_rotation(g[:3, :3])),
            }
            self._key = key

    def distance_to_axis(self, point: np.ndarray) -> tuple[float, float]:
        """``(radial, axial)`` distances (m) of a world point from the axis segment:
        radial = distance to the infinite axis line, axial = signed position along
        the axis from the centre."""
        d = point - self.world_T_centre[:3, 3]
        a = self.axis
        axial = float(d @ a)
        radial = norm(d - axial * a)
        return radial, axial

    def pose_dict(self) -> dict:
        """JSON-able pose of the centre and grasp frames (position m, rpy rad; new lists)."""
        self._refresh()
        return {k: list(v) for k, v in self._dict.items()}


def pipe_rest_depth(floor_depth: float, float_height: float, radius: float) -> float:
    """World z (m) of the axis of a pipe floating ``float_height`` above the floor."""
    return floor_depth - float_height - radius


def pool_bounds(
    size: tuple[float, float, float], half_height: float = HULL_HALF_HEIGHT_M
) -> tuple[tuple[float, float], ...]:
    """(low, high) of x, y, z (m) for the vehicle reference point in a pool of ``size``,
    for a hull reaching ``half_height`` (m) below that point."""
    return ((0.0, size[0]), (0.0, size[1]), (0.0, size[2] - half_height))


def clamp_to_pool(eta: np.ndarray, size: tuple[float, float, float], half_height: float = HULL_HALF_HEIGHT_M) -> bool:
    """Keep the vehicle reference point inside the pool (in place); True if it was clamped."""
    clamped = False
    bounds = pool_bounds(size, half_height)
    for i in range(3):
        lo, hi = bounds[i]
        v = eta[i]
        if v < lo or v > hi:
            eta[i] = min(max(v, lo), hi)
            clamped = True
    return clamped
