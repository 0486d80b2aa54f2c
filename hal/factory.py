"""Build a :class:`hal.interfaces.Backend` from a validated :class:`hal.config.HalConfig`.

``driver: sim`` everywhere -> the simulator (the builder :mod:`sim_backend`
registers with :mod:`hal.backends` when it is imported: the HAL never imports
the simulator, and runs without it on a vehicle); no ``sim`` -> a
:class:`hal.drivers.backend.RealBackend` with one driver per role and one shared
CANopen bus per ``buses`` entry (arm and gripper on the same bus share it); some
roles ``sim`` and others real -> a :class:`hal.mixed.MixedBackend` (e.g. the real
vehicle with a simulated arm).

Building does not touch the hardware; ``backend.open()`` connects.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING, Any, cast

from hal.backends import simulator
from hal.config import OPERATOR_ROLES, HalConfig
from hal.drivers.backend import RealBackend, UnavailableDevice
from hal.drivers.pushed_input import PushedInput
from hal.drivers.realtime import MonotonicClock
from hal.interfaces import Arm, Backend, DeviceSet, OperatorInput, Vehicle
from hal.mixed import MixedBackend
from maris_common.yamlsrc import ConfigError, ConfigIssue

if TYPE_CHECKING:  # its module loads python-can and canopen: imported when a config has a CAN bus
    from hal.drivers.canbus import CanopenBus

DEFAULT_SCENARIO = "pool_clear"


class DeviceUnavailable(RuntimeError):
    """A configured device or bus cannot be reached (e.g. CAN interface missing)."""


def build_backend(
    config: HalConfig,
    *,
    seed: int = 0,
    scenario: Any = None,
    realtime: bool | None = None,
    failed: dict[str, str] | None = None,
) -> Backend:
    """The backend the config describes.

    seed, scenario (name, path or already-loaded scenario; default: the config's
    ``sim.scenario``) and realtime (pace the simulation to wall time) apply to
    the simulator only; real hardware is always real time. ``failed`` (real
    devices; for ``maris hal check``): instead of raising, a device that cannot
    be built (bus missing, unusable EDS, ...) is recorded there (role -> reason)
    and stands in as an :class:`hal.drivers.backend.UnavailableDevice`.
    """
    if config.is_sim:
        return _build_sim(config, seed=seed, scenario=scenario, realtime=bool(realtime))
    if config.uses_simulator:
        return _attach_detector(_build_mixed(config, seed=seed, scenario=scenario, failed=failed))
    return _attach_detector(_build_real(config, failed=failed))


def _attach_detector(backend: Backend) -> Backend:
    """A real detector reads the attitude (gravity) and the joint angles (arm mask)
    from the backend's vehicle and arm, real or simulated."""
    attach = getattr(backend.devices.detector, "attach", None)
    if attach is not None:
        attach(vehicle=backend.devices.vehicle, arm=backend.devices.arm)
    return backend


def _build_mixed(config: HalConfig, *, seed: int, scenario: Any, failed: dict[str, str] | None = None) -> Backend:
    real = _build_real(config, skip_sim=True, failed=failed)
    try:
        sim = _build_sim(config, seed=seed, scenario=scenario, realtime=False)
    except Exception:
        real.close()
        raise
    roles = {}
    for role, dc in config.devices.items():
        source = sim.devices if dc.driver == "sim" else real.devices
        roles[role] = source.by_role()[role]
    return MixedBackend(real, sim, DeviceSet.from_roles(roles), follow_vehicle=config.follow_vehicle)


def _build_sim(config: HalConfig, *, seed: int, scenario: Any, realtime: bool) -> Backend:
    build = simulator()
    if build is None:
        raise DeviceUnavailable(
            f"{config.path}: `driver: sim` needs the simulator, which is not loaded in this process "
            "(import sim_backend: it registers itself with hal.backends)"
        )
    scen = scenario if scenario is not None else (config.scenario or DEFAULT_SCENARIO)
    backend = build(scen, seed=seed, realtime=realtime)
    # Only the roles the config lists are visible to the mission (the simulator may model more).
    full = backend.devices
    missing = sorted(r for r in config.roles if r not in full.by_role())
    if missing:
        backend.close()
        raise DeviceUnavailable(f"{config.path}: the simulator does not model {', '.join(missing)}")
    operators: dict[str, OperatorInput] = {}
    for role in sorted(config.operator_roles):
        dc = config.devices[role]  # senders stamp in the simulated time the live server publishes
        operators[role] = (
            full.operators[role]
            if dc.driver == "sim"
            else make_operator_input(role, dc, backend.clock.now, backend.clock.now)
        )
    backend.devices = DeviceSet(
        vehicle=full.vehicle,
        arm=full.arm,
        gripper=full.gripper if "gripper" in config.roles else None,
        detector=full.detector if "detector" in config.roles else None,
        wrench_sensor=full.wrench_sensor if "wrench_sensor" in config.roles else None,
        operators=operators,
    )
    return backend


def _build_real(config: HalConfig, skip_sim: bool = False, failed: dict[str, str] | None = None) -> Backend:
    clock = MonotonicClock()
    buses: dict[str, Any] = {}
    releases = []

    def bus_for(name: str) -> CanopenBus:
        if name not in buses:
            from hal.drivers.canbus import CanopenBus, open_can_bus  # python-can and canopen: see _make_device

            bc = config.buses[name]
            if bc.interface == "socketcan" and not Path(f"/sys/class/net/{bc.channel}").exists():
                raise DeviceUnavailable(
                    f"{bc.mark}: bus `{name}`: CAN interface {bc.channel} does not exist on this computer; plug in the "
                    f"CAN adapter and bring it up (sudo ip link set {bc.channel} type can bitrate "
                    f"{bc.options.get('bitrate', 1000000)} && sudo ip link set {bc.channel} up, see docs/field.md), "
                    "or put those roles on the simulator (driver: sim, e.g. hal/configs/bluerov2_sim_arm.yaml)"
                )
            try:
                raw = open_can_bus(bc.interface, bc.channel, **bc.options)
            except Exception as exc:  # noqa: BLE001 - python-can raises many kinds
                raise DeviceUnavailable(
                    f"{bc.mark}: bus `{name}` ({bc.interface} {bc.channel}): cannot open: {exc}"
                ) from None
            buses[name] = CanopenBus(raw, clock.now, host_node_id=bc.host_node_id, sync_period=bc.sync_period)
            releases.append(buses[name].close)
        return buses[name]

    devs: dict[str, Any] = {}
    try:
        for role, dc in config.devices.items():
            if dc.driver == "sim" and skip_sim:
                continue
            try:
                devs[role] = _make_device(role, dc, clock, bus_for)
            except Exception as exc:  # noqa: BLE001 - recorded for hal check, else re-raised below
                if failed is None or isinstance(exc, ConfigError):
                    raise
                failed[role] = str(exc)
                devs[role] = UnavailableDevice(role, str(exc), clock.now)
    except Exception:
        for release in releases:
            release()
        raise
    # the config has every required role; the real part of a mixed setup lacks those on the
    # simulator (None: the mixed backend reads only its by_role())
    devices = DeviceSet(
        vehicle=cast(Vehicle, devs.get("vehicle")),
        arm=cast(Arm, devs.get("arm")),
        gripper=devs.get("gripper"),
        detector=devs.get("detector"),
        wrench_sensor=devs.get("wrench_sensor"),
        operators={r: d for r, d in devs.items() if r in OPERATOR_ROLES},
    )
    return RealBackend(clock, devices, releases)


def make_operator_input(
    role: str, dc: Any, clock: Callable[[], float], stamp_clock: Callable[[], float] | None
) -> OperatorInput:
    """A real operator input: ``evdev_gamepad``, or an input the live server (``foxglove``)
    or the key reader (``terminal``) feeds. ``stamp_clock``: the clock of the stamps its
    senders put on commands (the wall clock on a vehicle, simulated time in a simulation)."""
    if dc.driver == "evdev_gamepad":
        from hal.drivers.gamepad import EvdevGamepad  # the evdev package is imported when it opens a pad

        return EvdevGamepad(dc.params, clock)
    if dc.driver in ("foxglove", "terminal"):
        return PushedInput(role, clock, stamp_clock)
    raise ConfigError([ConfigIssue(dc.mark, ("devices", role, "driver"), f"driver `{dc.driver}` has no builder")])


def _make_device(role: str, dc: Any, clock: Any, bus_for: Any) -> Any:
    """One real device from its validated config entry. Each driver's module is imported
    here, when a config names it: it loads its protocol library (canopen, pymavlink,
    OpenCV and the vision pipeline), which a setup without that device does not need."""
    p = dc.params
    if role in OPERATOR_ROLES:
        return make_operator_input(role, dc, clock.now, time.time)
    if dc.driver == "ardusub":
        from hal.drivers.vehicle_ardusub import ArdusubVehicle

        return ArdusubVehicle(p, clock.now)
    if dc.driver == "canopen_arm":
        from hal.drivers.arm_canopen import CanopenArm

        return CanopenArm(bus_for(p["bus"]), p, clock.now)
    if dc.driver == "canopen_gripper":
        from hal.drivers.gripper_canopen import CanopenGripper

        return CanopenGripper(bus_for(p["bus"]), p, clock.now)
    if dc.driver == "reach_arm":
        from hal.drivers.reach_arm import ReachArm

        return ReachArm(p, clock.now)
    if dc.driver == "reach_jaw":
        from hal.drivers.reach_jaw import ReachJaw

        return ReachJaw(p, clock.now)
    if dc.driver == "stereo_pipe_detector":
        from hal.drivers.pipe_detector import StereoPipeDetector

        return StereoPipeDetector(p, clock.now)
    if dc.driver == "mono_pipe_detector":
        try:
            import av  # noqa: F401 - the H.264 decoder, an optional dependency (the `camera` extra)
        except ImportError:
            raise DeviceUnavailable(
                f"{dc.mark}: devices.{role}: mono_pipe_detector decodes the camera's H.264 with PyAV, "
                "which is not installed: pip install 'maris-uvms[camera]'"
            ) from None
        from hal.drivers.mono_detector import MonoPipeDetector

        return MonoPipeDetector(p, clock.now)
    # validated configs cannot get here
    raise ConfigError([ConfigIssue(dc.mark, ("devices", role, "driver"), f"driver `{dc.driver}` has no builder")])
