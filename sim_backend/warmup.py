"""Compile (first time) or load the simulator's Numba kernels: ``python -m sim_backend.warmup``.

The full vehicle model (:mod:`sim_backend.vehicle_kernel`, :mod:`sim_backend.thrusters`,
the coupling :mod:`sim_backend.coupling_kernel`; with and without the coupling),
the arm, commands and readings (:mod:`sim_backend.step_kernel`), the AHRS
(:mod:`sim_backend.sensor_kernel`) and the table vision's image geometry
(:mod:`sim_backend.vision_kernel`: the backend takes its first image when it is
built) are compiled once per machine and cached next to the sources; ``make`` runs this
at install so the first dry run or test does not pay for it.
"""

from __future__ import annotations

import time

import numpy as np

from sim_backend import SimBackend, load_scenario


def main() -> None:
    t0 = time.perf_counter()

    sim = SimBackend(load_scenario("pool_fixed"), seed=0)
    sim.open()
    sim.advance(0.02)
    d = sim.devices
    d.vehicle.arm()
    d.arm.enable()
    d.vehicle.command_body_velocity(np.zeros(6))
    d.arm.command_joint_velocity(np.zeros(len(d.arm.joint_names)))
    sim.advance(0.01)
    d.vehicle.navigation()
    d.arm.joint_state()
    # the full vehicle without the arm's coupling takes another compiled step
    SimBackend(load_scenario("pool_fixed", {"arm.coupling": False}), seed=0).advance(0.01)
    print(f"simulator kernels ready ({time.perf_counter() - t0:.1f} s)")


if __name__ == "__main__":
    main()
