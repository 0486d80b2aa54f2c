"""Backends that live outside the HAL and register themselves with it.

The HAL builds the real devices itself (:mod:`hal.drivers`). The simulator is
another package (:mod:`sim_backend`) built on the HAL's interfaces: it registers
its builder here when it is imported, and the HAL never imports it. The entry
points that may run the simulator (``maris sim``, ``maris run`` with a
``driver: sim`` role, ``maris hal check``, :func:`mission.runtime.api.run_mission`)
import :mod:`sim_backend` themselves.
"""

from __future__ import annotations

from typing import Protocol

from hal.interfaces import Backend


class SimulatorBuilder(Protocol):
    """Builds the simulator for ``scenario`` (a scenario name or path, or one already
    loaded), drawing its randomness from ``seed``; ``realtime`` paces it to wall time."""

    def __call__(self, scenario: object, *, seed: int, realtime: bool) -> Backend: ...


_simulator: SimulatorBuilder | None = None


def register_simulator(builder: SimulatorBuilder) -> None:
    """Make ``builder`` the simulator the HAL builds for ``driver: sim`` roles."""
    global _simulator
    _simulator = builder


def simulator() -> SimulatorBuilder | None:
    """The registered simulator builder (None: no simulator imported in this process)."""
    return _simulator
