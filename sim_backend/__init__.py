"""Simulator of the UVMS (vehicle, arm, gripper, sensors, vision, pool).

Public API::

    from sim_backend import SimBackend, load_scenario
    sc = load_scenario("pool_clear", overrides={"dvl.noise_std_mps": 0.02})
    sim = SimBackend(sc, seed=7)           # a hal.interfaces.Backend
    sim.open(); sim.devices.vehicle.arm()
    sim.devices.vehicle.command_body_velocity(v); sim.advance(0.01)
    sim.ground_truth()["tool_to_target_m"]

Module map: :mod:`.scenario` / :mod:`.schema` / :mod:`.schema_dynamics` (files
and parameters), :mod:`.world` (pool, pipe), the vehicle: :mod:`.full_vehicle`
(default: DCL + thrusters + 6-DOF rigid body, with :mod:`.vehicle_kernel`,
:mod:`.thrusters`, :mod:`.hydrodynamics`, :mod:`.coupling` for the arm's
reaction through Pinocchio, :mod:`.step_kernel` for the arm drives, the
coupling's inputs, the device commands and joint readings, compiled) or :mod:`.vehicle_dynamics` (``vehicle.model:
first_order``, a fast kinematic lag for quick dry runs); :mod:`.arm_sim`,
:mod:`.gripper_sim`, :mod:`.grasp` (when a grasp holds), :mod:`.sensors` (DVL,
AHRS, depth, navigation) with :mod:`.gyro` (gyro noise spectrum) and
:mod:`.sensor_kernel` (the AHRS sample, compiled),
:mod:`.vision`, :mod:`.devices` (HAL adapters), :mod:`.backend` (lockstep,
faults, ground truth), :mod:`.rng` (seeded streams), :mod:`.geometry`.
``python -m sim_backend list|check|show`` inspects scenarios. Importing the
package registers the simulator with :mod:`hal.backends` (``driver: sim``).

Known simplifications: no collisions (an arm below the floor is only flagged),
the arm's joint motion is imposed by its drives (their torques are not
simulated), arm links have no drag and no wet weight, no added-mass Coriolis
terms, contact forces while closing are not on the wrench sensor, vision errors
are white (no calibration bias).
"""

from __future__ import annotations

from pathlib import Path

from hal.backends import register_simulator

from .backend import FAULTS, SimBackend
from .scenario import Choice, Range, Scenario, available_scenarios, load_scenario


def build_simulator(scenario: object, *, seed: int, realtime: bool) -> SimBackend:
    """The simulator for ``scenario`` (a name or path, loaded here, or a :class:`Scenario`):
    the builder registered with :mod:`hal.backends` for ``driver: sim`` roles."""
    if isinstance(scenario, (str, Path)):
        scenario = load_scenario(scenario)
    if not isinstance(scenario, Scenario):
        raise TypeError(f"a scenario name, path or Scenario, not {type(scenario).__name__}")
    return SimBackend(scenario, seed, realtime=realtime)


register_simulator(build_simulator)

__all__ = [
    "FAULTS",
    "Choice",
    "Range",
    "Scenario",
    "SimBackend",
    "available_scenarios",
    "build_simulator",
    "load_scenario",
]
