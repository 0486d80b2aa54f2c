"""Small pure geometry helpers for the leaves (world NED, vehicle FRD, SI units)."""

from __future__ import annotations

import numpy as np

from hal.interfaces import Detection, NavigationState
from kcl.rotations import pose_matrix

from .nav_history import NavHistory


def vehicle_pose_world(nav: NavigationState) -> np.ndarray:
    """World pose ``wTv`` (4, 4) of the vehicle from a navigation state."""
    eta = np.concatenate([np.asarray(nav.position, float), np.asarray(nav.attitude, float)])
    return pose_matrix(eta)


def grasp_pose_world(nav: NavigationState, detection: Detection, history: NavHistory | None = None) -> np.ndarray:
    """World pose ``wTg = wTv @ vTg`` (4, 4) of a detected grasp frame.

    The vehicle pose is taken at the detection's image time from ``history``
    (a :class:`behaviours.nav_history.NavHistory`) when it has samples, else
    ``nav`` (the latest navigation state) is used.
    """
    eta = history.eta_at(detection.t) if history is not None and len(history) else None
    wTv = pose_matrix(eta) if eta is not None else vehicle_pose_world(nav)
    return wTv @ np.asarray(detection.pose, float)


def distance_to_goal(nav: NavigationState, goal_xyz: np.ndarray) -> float:
    """Euclidean distance (m) from the vehicle position to a world NED point."""
    return float(np.linalg.norm(np.asarray(nav.position, float)[:3] - np.asarray(goal_xyz, float)[:3]))


def heading_error(nav: NavigationState, yaw_goal: float) -> float:
    """Absolute heading error (rad, in [0, pi]) between the vehicle yaw and ``yaw_goal`` (rad)."""
    d = float(nav.attitude[2]) - float(yaw_goal)
    return abs((d + np.pi) % (2 * np.pi) - np.pi)
