"""The grasp rule: when closing fingers touch the pipe, and whether it then stays.

Pure functions on world poses (4x4, NED, m). The fingers touch the pipe when
its axis passes within ``capture_radius`` of the tool origin, between the pipe's
ends. At that moment the grasp *holds* only if the tool frame is within tolerance
of the pipe's grasp frame: origin distance <= ``position_tolerance`` and angle
between the tool x axis and the pipe axis line <= ``axis_tolerance``. Otherwise
the fingers squeeze the pipe off-centre and it squirts out sideways
(:func:`slip_displacement`).
"""

from __future__ import annotations

import numpy as np

from .geometry import line_axis_angle
from .world import Pipe

#: Extra distance (m) beyond the hand's reach that a slipping pipe is pushed.
SLIP_CLEARANCE_M = 0.05


def hand_reaches_pipe(tool_pose: np.ndarray, pipe: Pipe, capture_radius: float) -> bool:
    """True if closing fingers around the tool origin would touch the pipe."""
    radial, axial = pipe.distance_to_axis(tool_pose[:3, 3])
    return radial <= capture_radius and abs(axial) <= 0.5 * pipe.length


def grasp_errors(tool_pose: np.ndarray, grasp_pose: np.ndarray) -> tuple[float, float]:
    """``(position error m, axis error rad)`` of the tool frame w.r.t. the grasp frame;
    the axis error ignores the direction of the pipe axis (a cylinder is symmetric)."""
    return float(np.linalg.norm(tool_pose[:3, 3] - grasp_pose[:3, 3])), line_axis_angle(tool_pose[:3, 0], grasp_pose[:3, 0])


def grasp_holds(position_error: float, axis_error: float, position_tolerance: float, axis_tolerance: float) -> bool:
    return position_error <= position_tolerance and axis_error <= axis_tolerance


def slip_displacement(tool_position: np.ndarray, pipe: Pipe, capture_radius: float) -> np.ndarray:
    """World displacement (3,) of a pipe squeezed out of a badly placed hand:
    horizontal, perpendicular to its axis, away from the tool, out of reach."""
    axis = pipe.axis
    away = pipe.world_T_centre[:3, 3] - tool_position
    away = away - (away @ axis) * axis
    away[2] = 0.0
    norm = float(np.linalg.norm(away))
    away = away / norm if norm > 1e-9 else np.cross(axis, [0.0, 0.0, 1.0])
    return (capture_radius + pipe.radius + SLIP_CLEARANCE_M) * away
