"""Helpers shared by the simulator tests (imported via the conftest's sys.path entry)."""

from __future__ import annotations

import numpy as np

from sim_backend import SimBackend

#: Vehicle that does exactly what it is told, on a quiet pool (first-order model).
PERFECT_TRACKING = {
    "vehicle.model": "first_order",
    "vehicle.time_constant_s": [0, 0, 0, 0, 0, 0],
    "vehicle.dead_band": [0, 0, 0, 0, 0, 0],
    "vehicle.low_speed_gain": [1, 1, 1, 1, 1, 1],
    "vehicle.disturbance_std": [0, 0, 0, 0, 0, 0],
    "current.velocity_mps": [0, 0, 0],
    "arm.time_constant_s": 0.0,
}


#: A vehicle that tracks small velocity references badly (first-order model):
#: wide dead band, half gain near zero, the usual lag and disturbance.
LARGE_TRACKING_ERROR = {
    "vehicle.model": "first_order",
    "vehicle.dead_band": [0.02, 0.02, 0.02, 0.01, 0.01, 0.02],
    "vehicle.low_speed_gain": [0.5, 0.5, 0.5, 0.5, 0.5, 0.5],
    "vehicle.low_speed_scale": [0.05, 0.05, 0.05, 0.03, 0.03, 0.05],
    "vehicle.disturbance_std": [0.01, 0.01, 0.005, 0.003, 0.003, 0.005],
}


def run(sim: SimBackend, seconds: float, dt: float = 0.01) -> None:
    for _ in range(int(round(seconds / dt))):
        sim.advance(dt)


def vehicle_pose_for_grasp(sim: SimBackend, model, q: np.ndarray) -> np.ndarray:
    """eta that puts the tool frame (arm at ``q``) exactly on the pipe's grasp frame."""
    from sim_backend.geometry import inverse_pose, rpy_from_rotation

    wTg = sim.pipe_grasp_pose()
    vTt = model.frame_pose_vehicle(q, "tool")
    wTv = wTg @ inverse_pose(vTt)
    roll, pitch, yaw = rpy_from_rotation(wTv[:3, :3])
    return np.array([*wTv[:3, 3], roll, pitch, yaw])


#: The fast first-order vehicle model with the shipped tracking parameters.
FIRST_ORDER = {"vehicle.model": "first_order"}
