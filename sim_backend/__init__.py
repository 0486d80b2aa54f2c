"""Kinematic simulator of the UVMS (vehicle, arm, gripper, sensors, vision, pool).

Public API::

    from sim_backend import SimBackend, load_scenario
    sc = load_scenario("pool_clear", overrides={"dvl.noise_std_mps": 0.02})
    sim = SimBackend(sc, seed=7)           # a hal.interfaces.Backend
    sim.open(); sim.devices.vehicle.arm()
    sim.devices.vehicle.command_body_velocity(v); sim.advance(0.01)
    sim.ground_truth()["tool_to_target_m"]

Module map: :mod:`.scenario` / :mod:`.schema` (files and parameters),
:mod:`.world` (pool, pipe), :mod:`.vehicle_dynamics`, :mod:`.arm_sim`,
:mod:`.gripper_sim`, :mod:`.grasp` (when a grasp holds), :mod:`.sensors` (DVL,
AHRS, depth), :mod:`.vision`, :mod:`.devices` (HAL adapters), :mod:`.backend`
(lockstep, faults, ground truth), :mod:`.rng` (seeded streams), :mod:`.geometry`.
``python -m sim_backend list|check|show`` inspects scenarios.

Known simplifications: no collisions (an arm below the floor is only flagged),
no arm-vehicle dynamic coupling, contact forces while closing are not on the
wrench sensor, vision errors are white (no calibration bias).
"""

from __future__ import annotations

from .backend import FAULTS, SimBackend
from .scenario import Choice, Range, Scenario, available_scenarios, load_scenario

__all__ = ["FAULTS", "Choice", "Range", "Scenario", "SimBackend", "available_scenarios", "load_scenario"]
