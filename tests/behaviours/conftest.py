"""A small mission context for tick tests: the real simulator's devices and
clock, the real py_trees blackboard, an in-memory event list, and a recording
stand-in for the KCL controller (only for what its interface promises:
set_action / set_targets / stop / telemetry; the leaves never run the KCL)."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np
import py_trees
import pytest

from behaviours.context import EventList, MissionBlackboard
from sim_backend import SimBackend, load_scenario


@dataclass
class RecordingController:
    """Records the calls leaves make; ``converged`` / ``fault`` drive telemetry."""

    calls: list[tuple] = field(default_factory=list)
    action: str | None = None
    converged: bool = False
    fault: str | None = None
    stopped: bool = False
    targets: dict = field(default_factory=dict)
    #: time (s) of the "last controller step"; None: not reported
    t: float | None = None

    known: tuple[str, ...] = ("survey", "grasp", "transport", "hold")

    def set_action(self, name: str, t: float) -> None:
        if name not in self.known:
            raise KeyError(name)  # as UvmsController does
        self.calls.append(("set_action", name, t))
        self.action, self.stopped, self.converged = name, False, False

    def set_targets(self, **kwargs: Any) -> None:
        self.calls.append(("set_targets", kwargs))
        self.targets.update(kwargs)

    def stop(self, t: float) -> None:
        self.calls.append(("stop", t))
        self.stopped = True

    def telemetry(self) -> dict:
        """The fields of UvmsController.telemetry() the leaves read."""
        out = {
            "action": self.action,
            "stopped": self.stopped,
            "transition_progress": 1.0,
            "convergence": 0.0 if self.converged else 0.5,
            "fault": self.fault is not None,
            "fault_reason": self.fault or "",
        }
        if self.t is not None:
            out["t"] = self.t
        return out

    def names(self) -> list[str]:
        return [c[0] for c in self.calls]


class SimContext:
    """MissionContext over a SimBackend (see the module docstring)."""

    def __init__(self, sim: SimBackend, types: dict[str, str] | None = None, initial: dict | None = None):
        self.sim = sim
        self.devices = sim.devices
        self.controller = RecordingController()
        self.blackboard = MissionBlackboard(types or {}, initial)
        self.events = EventList()
        self.motion_stops = 0

    def now(self) -> float:
        return self.sim.clock.now()

    def stop_motion(self) -> None:
        self.motion_stops += 1
        self.controller.stop(self.now())
        self.devices.vehicle.command_body_velocity(np.zeros(6))
        self.devices.arm.command_joint_velocity(np.zeros(len(self.devices.arm.joint_names)))

    def advance(self, seconds: float, dt: float = 0.05) -> None:
        for _ in range(max(1, round(seconds / dt))):
            self.sim.advance(dt)


def tick_until(root: py_trees.behaviour.Behaviour, ctx: SimContext, max_s: float, dt: float = 0.1, step=None) -> py_trees.common.Status:
    """Tick ``root`` every ``dt`` s of sim time until it stops RUNNING or ``max_s`` passes."""
    for _ in range(int(max_s / dt) + 1):
        root.tick_once()
        if root.status != py_trees.common.Status.RUNNING:
            return root.status
        if step is not None:
            step(ctx)
        ctx.advance(dt, dt)
    return root.status


@pytest.fixture(scope="module")
def scenario():
    return load_scenario("pool_clear")


@pytest.fixture
def make_ctx(scenario):
    sims: list[SimBackend] = []

    def make(types: dict[str, str] | None = None, initial: dict | None = None, seed: int = 3) -> SimContext:
        sim = SimBackend(scenario, seed=seed)
        sim.open()
        sims.append(sim)
        return SimContext(sim, types, initial)

    yield make
    for sim in sims:
        sim.close()


@pytest.fixture
def tick():
    """The :func:`tick_until` helper (test modules cannot import conftest)."""
    return tick_until
