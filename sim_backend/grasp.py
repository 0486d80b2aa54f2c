"""The grasp rule: when closing fingers touch the pipe, and whether it then stays.

Pure functions on world poses (4x4, NED, m). The fingers touch the pipe when
its axis passes within ``capture_radius`` of the tool origin, between the pipe's
ends. At that moment the grasp *holds* if the hand's geometry encloses the
pipe, judged in the tool frame (z = approach, out of the palm; x = the axis of
a cylinder the fingers close around; y = across both):

* across: the distance from the pipe axis to the tool origin, along tool y,
  at most ``across_tolerance`` (the fingers sweep an off-centre pipe into the palm);
* approach: the same distance along tool z at most ``approach_tolerance`` (the
  fingers wrap the pipe, not its far or near surface);
* along the pipe axis the hand only needs to be on the pipe: the tool origin at
  least ``end_clearance`` from either end (where it sits between the ends does
  not matter to the hand);
* the angle between tool x and the pipe axis at most ``axis_tolerance``.

Otherwise the fingers squeeze the pipe off-centre and it squirts out sideways
(:func:`slip_displacement`). Where the tolerances come from:
``sim_backend/scenarios/pool_clear.yaml``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .geometry import line_axis_angle, norm
from .world import Pipe

#: Extra distance (m) beyond the hand's reach that a slipping pipe is pushed.
SLIP_CLEARANCE_M = 0.05


@dataclass(frozen=True)
class GraspTolerances:
    """Tolerances of the grasp rule (m, rad); see the module docstring."""

    across_m: float
    approach_m: float
    end_clearance_m: float
    axis_rad: float

    @classmethod
    def from_params(cls, p: dict) -> GraspTolerances:
        return cls(
            float(p["grasp.across_tolerance_m"]),
            float(p["grasp.approach_tolerance_m"]),
            float(p["grasp.end_clearance_m"]),
            float(p["grasp.axis_tolerance_rad"]),
        )


@dataclass(frozen=True)
class GraspOffsets:
    """Where the pipe is in the hand: ``across_m`` / ``approach_m`` signed offsets
    (m) of the pipe axis from the tool origin along tool y / z, ``along_m`` the
    tool origin's position along the axis from the pipe centre (m), ``axis_rad``
    the angle between tool x and the pipe axis."""

    across_m: float
    approach_m: float
    along_m: float
    axis_rad: float

    def failed_checks(self, tol: GraspTolerances, pipe_length: float) -> list[str]:
        """Names of the rules this grasp breaks (empty: it holds)."""
        out = []
        if abs(self.across_m) > tol.across_m:
            out.append("across")
        if abs(self.approach_m) > tol.approach_m:
            out.append("approach")
        if abs(self.along_m) > 0.5 * pipe_length - tol.end_clearance_m:
            out.append("along")
        if self.axis_rad > tol.axis_rad:
            out.append("axis")
        return out

    def as_dict(self) -> dict:
        return {
            "across_m": self.across_m,
            "approach_m": self.approach_m,
            "along_m": self.along_m,
            "axis_rad": self.axis_rad,
        }


def hand_reaches_pipe(tool_pose: np.ndarray, pipe: Pipe, capture_radius: float) -> bool:
    """True if closing fingers around the tool origin would touch the pipe."""
    radial, axial = pipe.distance_to_axis(tool_pose[:3, 3])
    return radial <= capture_radius and abs(axial) <= 0.5 * pipe.length


def grasp_offsets(tool_pose: np.ndarray, pipe: Pipe) -> GraspOffsets:
    """Offsets of the pipe in the hand (see :class:`GraspOffsets`)."""
    o = tool_pose[:3, 3]
    c = pipe.world_T_centre[:3, 3]
    a = pipe.axis
    along = float((o - c) @ a)
    foot = c + along * a  # point of the axis closest to the tool origin
    d = foot - o
    R = tool_pose[:3, :3]
    return GraspOffsets(float(d @ R[:, 1]), float(d @ R[:, 2]), along, line_axis_angle(R[:, 0], a))


def grasp_errors(tool_pose: np.ndarray, grasp_pose: np.ndarray) -> tuple[float, float]:
    """``(position error m, axis error rad)`` of the tool frame w.r.t. the grasp frame;
    the axis error ignores the direction of the pipe axis (a cylinder is symmetric)."""
    return norm(tool_pose[:3, 3] - grasp_pose[:3, 3]), line_axis_angle(tool_pose[:3, 0], grasp_pose[:3, 0])


def slip_displacement(tool_position: np.ndarray, pipe: Pipe, capture_radius: float) -> np.ndarray:
    """World displacement (3,) of a pipe squeezed out of a badly placed hand:
    horizontal, perpendicular to its axis, away from the tool, out of reach."""
    axis = pipe.axis
    away = pipe.world_T_centre[:3, 3] - tool_position
    away = away - (away @ axis) * axis
    away[2] = 0.0
    size = norm(away)
    away = away / size if size > 1e-9 else np.cross(axis, [0.0, 0.0, 1.0])
    return (capture_radius + pipe.radius + SLIP_CLEARANCE_M) * away
