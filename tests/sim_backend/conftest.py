"""Shared fixtures of the simulator tests."""

from __future__ import annotations

import sys
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).parent))

from kcl.model import UvmsModel  # noqa: E402
from sim_backend import SimBackend, load_scenario  # noqa: E402


@pytest.fixture(scope="session")
def model() -> UvmsModel:
    return UvmsModel.load()


@pytest.fixture
def make_sim(model):
    """``make_sim(scenario="pool_fixed", seed=0, **overrides)`` -> opened, armed SimBackend."""

    def make(
        scenario: str = "pool_fixed", seed: int = 0, overrides: dict | None = None, realtime: bool = False
    ) -> SimBackend:
        sim = SimBackend(load_scenario(scenario, overrides), seed, realtime=realtime, model=model)
        sim.open()
        sim.devices.vehicle.arm()
        sim.devices.arm.enable()
        return sim

    return make
