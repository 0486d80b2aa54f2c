"""Mission contexts for tick tests, on the real simulator's devices and clock,
the real py_trees blackboard and an in-memory event list:

* :class:`SimContext` with a recording stand-in for the KCL controller, for
  unit tick tests that must set convergence / faults at will (only what the
  controller interface promises: set_action / set_targets / stop / telemetry);
* :class:`KclSimContext` with the real :class:`kcl.controller.UvmsController`
  and a multi-rate loop standing in for the supervisor's (``run``)."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np
import py_trees
import pytest

from behaviours.context import EventList, MissionBlackboard, OperatorBoard
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

    def clear_targets(self) -> None:
        self.calls.append(("clear_targets",))
        self.targets.clear()

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
        self.operator = OperatorBoard()
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


def tick_until(
    root: py_trees.behaviour.Behaviour, ctx: SimContext, max_s: float, dt: float = 0.1, step=None
) -> py_trees.common.Status:
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


class KclSimContext:
    """MissionContext with the real controller; :meth:`run` is the multi-rate loop
    (tree at ``tree_hz``, vehicle KCL at ``vehicle_hz``, arm KCL at ``arm_hz``)."""

    def __init__(
        self,
        sim: SimBackend,
        controller: Any,
        blackboard: MissionBlackboard,
        tree_hz: float = 10.0,
        vehicle_hz: float = 10.0,
        arm_hz: float = 100.0,
    ):
        self.sim = sim
        self.devices = sim.devices
        self.devices.vehicle.arm()
        self.devices.arm.enable()
        self.controller = controller
        self.blackboard = blackboard
        self.events = EventList()
        self.operator = OperatorBoard()
        self.motion_stops = 0
        self.rates = (tree_hz, vehicle_hz, arm_hz)

    def now(self) -> float:
        return self.sim.clock.now()

    def stop_motion(self) -> None:
        self.motion_stops += 1
        self.controller.stop(self.now())
        self.devices.vehicle.command_body_velocity(np.zeros(6))
        self.devices.arm.command_joint_velocity(np.zeros(len(self.devices.arm.joint_names)))

    def measure(self):
        from kcl.controller import MeasuredState

        nav = self.devices.vehicle.navigation()
        js = self.devices.arm.joint_state()
        return MeasuredState(
            js.position, np.r_[nav.position, nav.attitude], nav.body_velocity, self.now(), nav.altitude
        )

    def run(self, root, max_s: float, until=None) -> py_trees.common.Status:
        """Tick ``root`` and step the KCL until ``root`` stops RUNNING, ``until()``, or ``max_s``."""
        tree_hz, vehicle_hz, arm_hz = self.rates
        dt = 1.0 / arm_hz
        per_vehicle, per_tree = round(arm_hz / vehicle_hz), round(arm_hz / tree_hz)
        for k in range(int(max_s / dt)):
            if k % per_tree == 0:
                root.tick_once()
                if root.status != py_trees.common.Status.RUNNING or (until is not None and until()):
                    return root.status
            if k % per_vehicle == 0:
                self.devices.vehicle.command_body_velocity(self.controller.vehicle_step(self.measure(), self.now()))
            self.devices.arm.command_joint_velocity(self.controller.arm_step(self.measure(), self.now()))
            self.sim.advance(dt)
        return root.status


@pytest.fixture(scope="session")
def kcl_parts():
    """The default model and actions (loaded once)."""
    from kcl.actions import load_actions
    from kcl.model import UvmsModel

    model = UvmsModel.load()
    return model, load_actions(model=model)


@pytest.fixture
def make_kcl_ctx(scenario, kcl_parts):
    from kcl.controller import UvmsController

    sims: list[SimBackend] = []

    def make(types: dict[str, str] | None = None, initial: dict | None = None, seed: int = 3, **rates) -> KclSimContext:
        model, actions = kcl_parts
        sim = SimBackend(scenario, seed=seed, model=model)
        sim.open()
        sims.append(sim)
        return KclSimContext(sim, UvmsController(model, actions), MissionBlackboard(types or {}, initial), **rates)

    yield make
    for sim in sims:
        sim.close()
