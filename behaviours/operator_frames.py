"""The frames an operator's clicked poses and points come in, to the world frame (NED).

The live view's 3D panel publishes a click in the frame it displays
(``geometry_msgs/PoseStamped`` / ``PointStamped``, ``header.frame_id``), on
that frame's ground plane (its z = 0): ``map`` (the z-up root of the log's
frame tree) or ``vehicle_level`` (``map``'s axes at the vehicle's position:
``mission.logs.frames``). A click there gives a north, an east and, for a pose,
a heading; its depth is the plane's, not a place the operator chose, so the
reader keeps a depth of its own (the vehicle's, the tool's, the bottom's):
:attr:`WorldPoint.depth_given` is False. A point given in ``world`` (NED) or
``base_link`` (the vehicle frame, FRD) is taken whole.

``map -> world`` is the fixed turn ``x_world = y_map``, ``y_world = x_map``,
``z_world = -z_map``; a heading ``psi_map`` about ``map``'s z (up, from east)
is ``pi/2 - psi_map`` about ``world``'s z (down, from north).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from hal.interfaces import NavigationState

#: Frames whose clicks lie on a ground plane (their z = 0): the depth is not the operator's.
GROUND_PLANE_FRAMES = ("map", "vehicle_level")
#: Every frame a pose or point may come in.
KNOWN_FRAMES = ("world", "base_link", *GROUND_PLANE_FRAMES)


@dataclass(frozen=True)
class WorldPoint:
    """A point in the world frame (NED, m), the heading that came with it (rad, world
    yaw; None for a point) and whether its depth is the operator's."""

    position: np.ndarray
    yaw: float | None
    depth_given: bool


class UnknownFrame(ValueError):
    """A pose or point in a frame this reader cannot place."""


def _rz(yaw: float) -> np.ndarray:
    c, s = math.cos(yaw), math.sin(yaw)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def vehicle_rotation(nav: NavigationState) -> np.ndarray:
    """World-from-vehicle rotation (Z-Y-X roll, pitch, yaw)."""
    r, p, y = (float(a) for a in nav.attitude)
    cr, sr, cp, sp = math.cos(r), math.sin(r), math.cos(p), math.sin(p)
    rx = np.array([[1.0, 0.0, 0.0], [0.0, cr, -sr], [0.0, sr, cr]])
    ry = np.array([[cp, 0.0, sp], [0.0, 1.0, 0.0], [-sp, 0.0, cp]])
    return _rz(y) @ ry @ rx


def to_world(values: np.ndarray, frame: str, nav: NavigationState) -> WorldPoint:
    """A point (3,) or a pose (4, 4) given in ``frame``, in the world frame (see the
    module docstring); ``nav``: the vehicle's pose now. UnknownFrame for another frame."""
    arr = np.asarray(values, dtype=float)
    pose = arr.shape == (4, 4)
    p = arr[:3, 3] if pose else arr.reshape(3)
    heading = math.atan2(arr[1, 0], arr[0, 0]) if pose else None  # about the frame's z
    vehicle = np.asarray(nav.position, dtype=float)
    if frame in GROUND_PLANE_FRAMES:
        offset = np.array([p[1], p[0], -p[2]])
        origin = vehicle if frame == "vehicle_level" else np.zeros(3)
        yaw = None if heading is None else _wrap(math.pi / 2 - heading)
        return WorldPoint(origin + offset, yaw, False)
    if frame == "world":
        return WorldPoint(p.copy(), heading, True)
    if frame == "base_link":
        R = vehicle_rotation(nav)
        yaw = None if heading is None else _wrap(float(nav.attitude[2]) + heading)
        return WorldPoint(vehicle + R @ p, yaw, True)
    raise UnknownFrame(f"frame `{frame}`: a pose or point must come in one of {', '.join(KNOWN_FRAMES)}")


def _wrap(a: float) -> float:
    return (a + math.pi) % (2 * math.pi) - math.pi
