"""HAL configuration files: which driver serves each device role, with its parameters.

A HAL config is user-written YAML (see ``hal/configs/``)::

    buses:                      # optional: CAN buses shared by CANopen devices
      can0: {interface: socketcan, channel: can0, bitrate: 1000000}
    devices:                    # role -> driver + parameters
      vehicle: {driver: ardusub, url: "udpin:0.0.0.0:14550", ...}
      arm:     {driver: canopen_arm, bus: can0, eds: ../data/cia402_minimal.eds, joints: [...]}
    sim:                        # only for driver "sim"
      scenario: pipe_recovery
    model: ../../kcl/data/bluerov2_heavy_alpha5.urdf   # optional: the rig's URDF
    actions: ../../kcl/data/bluerov2_alpha5_actions.yaml  # optional: its KCL actions

``model`` and ``actions`` name the rig these devices are, so that one mission runs
on several rigs with only the HAL config (and the scenario) differing: a
mission's own ``model`` / ``actions_file`` fields take precedence
(:mod:`mission.platform`).

:func:`load_hal_config` checks everything at once and raises
:class:`maris_common.yamlsrc.ConfigError` naming ``file:line:column`` and the field,
with did-you-mean suggestions for typos. Relative paths (EDS files) are resolved
against the config file's folder. The per-driver parameter schemas live in
:mod:`hal.config_schema` (:data:`DRIVER_SCHEMAS`); a new driver adds its schema
there and its builder in :mod:`hal.factory`.
"""

from __future__ import annotations

import copy
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from hal.config_schema import (
    ARDUSUB_HEARTBEAT_PERIOD_S,
    BUS_SCHEMA,
    DRIVER_SCHEMAS,
    OPERATOR_ROLES,
    REQUIRED_ROLES,
    RETIRED_KEYS,
    ROLES,
    SUB_MODES,
    Param,
)
from maris_common.yamlsrc import (
    ConfigError,
    ConfigIssue,
    Located,
    Mark,
    PathT,
    format_path,
    load_yaml,
    suggest,
    unknown_keys,
)
from vision.calibration import load_stereo_calibration

__all__ = [
    "ARDUSUB_HEARTBEAT_PERIOD_S",
    "SITE_KEY",
    "BusConfig",
    "ConfigSite",
    "DRIVER_SCHEMAS",
    "DeviceConfig",
    "HalConfig",
    "OPERATOR_ROLES",
    "Param",
    "REQUIRED_ROLES",
    "ROLES",
    "SUB_MODES",
    "load_hal_config",
    "site_of",
    "validate_hal_config",
]


# --------------------------------------------------------------------------- result

#: Key of a device's validated ``params`` holding its :class:`ConfigSite` (not a user field).
SITE_KEY = "_site"


@dataclass(frozen=True)
class ConfigSite:
    """Where a device's entry and each of its fields were written, so that a driver's
    set-up error names ``file:line:column`` and the field (e.g. a serial device that
    does not exist). ``marks``: path below ``devices.<role>`` -> mark."""

    role: str
    marks: dict[PathT, Mark]

    def at(self, *path: Any) -> str:
        """``file:line:column: devices.<role>.<path>`` of a field (or its nearest parent written)."""
        p = tuple(path)
        while p not in self.marks and p:
            p = p[:-1]
        mark = self.marks.get(p) or self.marks.get(())
        return f"{mark}: {format_path(('devices', self.role, *path))}"


def site_of(params: dict[str, Any], *path: Any) -> str:
    """:meth:`ConfigSite.at` of a device's params; ``devices`` alone for params not from a file."""
    site = params.get(SITE_KEY)
    return site.at(*path) if isinstance(site, ConfigSite) else format_path(("devices", *path))


@dataclass(frozen=True)
class DeviceConfig:
    """One configured device: its role, driver name, validated parameters (defaults
    filled in, paths absolute) and where it was written."""

    role: str
    driver: str
    params: dict[str, Any]
    mark: Mark


@dataclass(frozen=True)
class BusConfig:
    """One CAN bus: python-can ``interface`` and ``channel`` plus extra keyword arguments."""

    name: str
    interface: str
    channel: str
    options: dict[str, Any]
    mark: Mark
    host_node_id: int = 127
    #: s, period of the SYNC message this computer sends on the bus (None: no SYNC).
    sync_period: float | None = None


@dataclass(frozen=True)
class HalConfig:
    """A validated HAL configuration."""

    path: str
    devices: dict[str, DeviceConfig]
    buses: dict[str, BusConfig] = field(default_factory=dict)
    scenario: str | None = None
    #: a mixed run's simulated vehicle follows the real vehicle's navigation (``sim.follow_vehicle``)
    follow_vehicle: bool = False
    #: the rig's URDF and KCL actions file (absolute paths), None when the config names none
    model: str | None = None
    actions: str | None = None
    #: where ``model`` / ``actions`` are written (``file:line:column``), for error messages
    model_mark: Mark | None = None
    actions_mark: Mark | None = None

    @property
    def roles(self) -> frozenset[str]:
        """Roles present in the file (e.g. {"vehicle", "arm", "gripper"})."""
        return frozenset(self.devices)

    @property
    def is_sim(self) -> bool:
        """Every device role on the simulator (operator inputs may be real: a gamepad,
        the Foxglove live view, the keyboard drive a simulation as they drive a vehicle)."""
        return all(d.driver == "sim" for r, d in self.devices.items() if r not in OPERATOR_ROLES)

    @property
    def uses_simulator(self) -> bool:
        """Some role on the simulator (its builder must be registered: :mod:`hal.backends`)."""
        return any(d.driver == "sim" for d in self.devices.values())

    @property
    def operator_roles(self) -> frozenset[str]:
        """The operator input roles present (``gamepad``, ``foxglove``, ``keyboard``)."""
        return frozenset(r for r in self.devices if r in OPERATOR_ROLES)


# --------------------------------------------------------------------------- validation


def _check_simulated_operators(src: Located, devices: dict[str, DeviceConfig], issues: list[ConfigIssue]) -> None:
    """An operator input on the simulator (a recorded gamepad) plays in simulated time:
    it needs every device role on the simulator too."""
    real = sorted(r for r, d in devices.items() if r not in OPERATOR_ROLES and d.driver != "sim")
    if not real:
        return
    for role, dev in devices.items():
        if role in OPERATOR_ROLES and dev.driver == "sim":
            issues.append(
                src.issue(
                    ("devices", role, "driver"),
                    f"`{role}` on the simulator (a recorded input, in simulated time) needs every device on the "
                    f"simulator, but {', '.join(real)} {'is' if len(real) == 1 else 'are'} real; "
                    f"use a real input driver ({_real_operator_driver(role)})",
                )
            )


def _real_operator_driver(role: str) -> str:
    return {"gamepad": "evdev_gamepad", "foxglove": "foxglove", "keyboard": "terminal"}.get(role, "?")


_KIND_TYPES = {
    "str": (str,),
    "int": (int,),
    "float": (int, float),
    "bool": (bool,),
    "path": (str,),
    "map": (dict,),
    "record": (dict,),
    "list": (list,),
}


def _check_value(src: Located, path: PathT, spec: Param, value: Any, base: Path, issues: list[ConfigIssue]) -> Any:
    kind = spec.kind
    if isinstance(kind, tuple):
        if value not in kind:
            issues.append(
                src.issue(path, f"must be one of {', '.join(kind)}, got {value!r}{suggest(str(value), kind)}")
            )
            return None
        return value
    types = _KIND_TYPES[kind]
    if isinstance(value, bool) and kind in ("int", "float") or not isinstance(value, types):
        issues.append(src.issue(path, f"expected {kind}, got {type(value).__name__} {value!r}"))
        return None
    if kind == "float" and isinstance(value, (int, float)):  # checked above
        value = float(value)
        if value != value or value in (float("inf"), float("-inf")):
            issues.append(src.issue(path, "must be a finite number"))
            return None
    if spec.check is not None:
        err = spec.check(value)
        if err:
            issues.append(src.issue(path, err))
            return None
    if kind == "path":
        p = Path(value)
        p = p if p.is_absolute() else (base / p)
        if not p.is_file():
            issues.append(src.issue(path, f"file not found: {p}"))
            return None
        return str(p.resolve())
    if spec.item is not None and kind == "list":
        return [_check_mapping(src, path + (i,), it, spec.item, base, issues) for i, it in enumerate(value)]
    if kind == "record":
        return _check_mapping(src, path, value, spec.item or {}, base, issues)
    if spec.item is not None and kind == "map":
        return {k: _check_mapping(src, path + (k,), v, spec.item, base, issues) for k, v in value.items()}
    return value


def _check_mapping(
    src: Located, path: PathT, data: Any, schema: dict[str, Param], base: Path, issues: list[ConfigIssue]
) -> dict[str, Any]:
    if not isinstance(data, dict):
        issues.append(src.issue(path, f"expected a mapping, got {type(data).__name__}"))
        return {}
    issues.extend(unknown_keys(src, data, path, schema))
    out: dict[str, Any] = {}
    for name, spec in schema.items():
        if name not in data or data[name] is None:
            if spec.required:
                issues.append(src.issue(path, f"missing required field `{name}`"))
            out[name] = copy.deepcopy(spec.default)  # never share a mutable default between devices
            continue
        out[name] = _check_value(src, path + (name,), spec, data[name], base, issues)
    return out


def _check_device(
    src: Located, role: str, data: Any, base: Path, buses: dict, issues: list[ConfigIssue]
) -> DeviceConfig | None:
    path: PathT = ("devices", role)
    if not isinstance(data, dict):
        issues.append(src.issue(path, "expected a mapping with at least `driver`"))
        return None
    driver = data.get("driver")
    if not isinstance(driver, str) or driver not in DRIVER_SCHEMAS:
        where = path + ("driver",) if "driver" in data else path
        what = (
            f"unknown driver `{driver}`{suggest(str(driver), DRIVER_SCHEMAS)}"
            if driver is not None
            else "missing required field `driver`"
        )
        issues.append(src.issue(where, f"{what}; known drivers: {', '.join(sorted(DRIVER_SCHEMAS))}"))
        return None
    allowed_roles, schema = DRIVER_SCHEMAS[driver]
    if role not in allowed_roles:
        issues.append(
            src.issue(
                path + ("driver",),
                f"driver `{driver}` cannot serve role `{role}` (it serves {', '.join(allowed_roles)})",
            )
        )
        return None
    retired = {k for k in data if (driver, k) in RETIRED_KEYS}
    issues.extend(src.issue(path + (k,), RETIRED_KEYS[(driver, k)]) for k in sorted(retired))
    params = _check_mapping(
        src, path, {k: v for k, v in data.items() if k != "driver" and k not in retired}, schema, base, issues
    )
    if "bus" in schema and params.get("bus") is not None and params["bus"] not in buses:
        issues.append(
            src.issue(
                path + ("bus",),
                f"unknown bus `{params['bus']}`{suggest(params['bus'], buses)}; define it under `buses`",
            )
        )
    if driver == "ardusub" and params.get("command") == "setpoint" and params.get("arm_mode") not in (None, "GUIDED"):
        issues.append(
            src.issue(
                path + ("arm_mode",),
                "velocity setpoints are only followed in GUIDED; use arm_mode: GUIDED or command: manual_control",
            )
        )
    if driver == "ardusub" and params.get("command") == "manual_control":
        if params.get("arm_mode") not in ("MANUAL", "STABILIZE", "ALT_HOLD", "ACRO"):
            issues.append(
                src.issue(
                    path + ("arm_mode",), "MANUAL_CONTROL sticks need a pilot mode: MANUAL, STABILIZE, ALT_HOLD or ACRO"
                )
            )
        if not params.get("manual_full_stick") and "manual_full_stick" not in data:
            issues.append(
                src.issue(
                    path,
                    "command: manual_control is open loop (sticks are thrust, not velocity): give "
                    "`manual_full_stick: {surge_mps, sway_mps, heave_mps, yaw_rad_s}`, the speeds "
                    "measured at full stick on this vehicle (see docs/field.md)",
                )
            )
    for sensor in ("dvl", "ahrs", "ping"):
        cfg = params.get(sensor)
        if cfg and cfg.get("transport") == "serial" and not cfg.get("device"):
            issues.append(src.issue(path + (sensor,), "serial transport needs `device` (e.g. /dev/ttyUSB0)"))
        if cfg and cfg.get("transport") == "udp" and not cfg.get("host"):
            issues.append(src.issue(path + (sensor,), "udp transport needs `host`"))
    if driver == "stereo_pipe_detector":
        _check_cameras(src, path, params, base, issues)
    host_id = buses[params["bus"]].host_node_id if params.get("bus") in buses else None
    if driver == "canopen_arm" and params.get("joints"):
        _check_unique_nodes(src, path + ("joints",), [j.get("node_id") for j in params["joints"]], host_id, issues)
    if driver == "canopen_gripper" and params.get("motors"):
        _check_unique_nodes(
            src, path + ("motors",), [m.get("node_id") for m in params["motors"].values()], host_id, issues
        )
    if driver.startswith("canopen_"):
        _check_canopen_timing(src, path, params, buses.get(params.get("bus")), issues)
    n = len(path)
    params[SITE_KEY] = ConfigSite(role, {k[n:]: m for k, m in src.marks.items() if k[:n] == path})
    return DeviceConfig(role, driver, params, src.mark(path))


def _check_cameras(src: Located, path: PathT, params: dict, base: Path, issues: list[ConfigIssue]) -> None:
    """Either `left` + `right` or `side_by_side`; file and folder sources exist
    (made absolute against the config's folder)."""
    if params.get("calibration"):
        try:
            load_stereo_calibration(params["calibration"], params.get("calibration_right"))
        except ConfigError as exc:
            issues.extend(exc.issues)
    pair, sbs = (
        params.get("left") is not None or params.get("right") is not None,
        params.get("side_by_side") is not None,
    )
    if sbs and pair:
        issues.append(src.issue(path, "give either `left` and `right` or `side_by_side`, not both"))
    elif not sbs and (params.get("left") is None or params.get("right") is None):
        issues.append(src.issue(path, "missing camera: give `left` and `right` (or `side_by_side`)"))
    for name in ("left", "right", "side_by_side"):
        cam = params.get(name)
        if not cam or not isinstance(cam.get("source"), str):
            continue
        source = cam["source"].strip()
        live = source.isdigit() or source.startswith("/dev/video") or "!" in source or "://" in source
        if live:
            continue
        p = Path(source)
        p = p if p.is_absolute() else base / p
        if not p.exists():
            issues.append(
                src.issue(
                    path + (name, "source"),
                    f"camera source not found: {p} (a file or folder; or a device, URL or GStreamer pipeline)",
                )
            )
        else:
            cam["source"] = str(p.resolve())


def _check_canopen_timing(src: Located, path: PathT, p: dict, bus: BusConfig | None, issues: list[ConfigIssue]) -> None:
    """Timing settings of CANopen drives that only make sense together."""
    hb, hb_to, stale = p.get("heartbeat_period"), p.get("heartbeat_timeout"), p.get("stale_timeout")
    if hb and hb_to and hb_to < 2 * hb:
        issues.append(src.issue(path + ("heartbeat_timeout",), f"must be at least twice heartbeat_period ({hb:g} s)"))
    sync = bus.sync_period if bus is not None else None
    if p.get("transmission") == "sync":
        if not sync:
            issues.append(
                src.issue(
                    path + ("transmission",), f"`sync` needs a SYNC producer: set `sync_period` on bus `{p.get('bus')}`"
                )
            )
        elif stale and stale < 2 * sync:
            issues.append(
                src.issue(path + ("stale_timeout",), f"must be at least twice the bus sync_period ({sync:g} s)")
            )
    if p.get("transmission") == "event_timer" and stale and p.get("pdo_period") and stale < 2 * p["pdo_period"]:
        issues.append(
            src.issue(path + ("stale_timeout",), f"must be at least twice pdo_period ({p['pdo_period']:g} s)")
        )


_REACH_LINK_KEYS = ("transport", "device", "baudrate", "host", "port", "local_port", "guardian", "guard_timeout")


def _check_reach(src: Located, devices: dict[str, DeviceConfig], issues: list[ConfigIssue]) -> None:
    """Reach arm links: serial needs `device`, udp `host`; a jaw with `link: arm` takes the
    arm's link settings; device ids are unique on a link."""
    arm = devices.get("arm")
    for role, dev in devices.items():
        if not dev.driver.startswith("reach_"):
            continue
        p = dev.params
        if dev.driver == "reach_jaw" and p.get("link") == "arm":
            if arm is None or arm.driver != "reach_arm":
                issues.append(src.issue(("devices", role, "link"), "`link: arm` needs the arm on `driver: reach_arm`"))
                continue
            p.update({k: arm.params.get(k) for k in _REACH_LINK_KEYS})
        elif dev.driver == "reach_jaw" and p.get("transport") is None:
            issues.append(src.issue(("devices", role), "give `link: arm` (the jaw on the arm's link) or `transport`"))
            continue
        if p.get("transport") == "serial" and not p.get("device"):
            issues.append(src.issue(("devices", role), "serial transport needs `device` (e.g. /dev/ttyUSB0)"))
        if p.get("transport") == "udp" and not p.get("host"):
            issues.append(src.issue(("devices", role), "udp transport needs `host` (the arm's address)"))
    ids: dict[int, str] = {}
    if arm is not None and arm.driver == "reach_arm":
        for i, j in enumerate(arm.params.get("joints") or []):
            did = j.get("device_id")
            if did in ids:
                issues.append(src.issue(("devices", "arm", "joints", i, "device_id"), f"device id {did} used twice"))
            ids[did] = j.get("name")
        jaw = devices.get("gripper")
        if jaw is not None and jaw.driver == "reach_jaw" and jaw.params.get("device_id") in ids:
            issues.append(
                src.issue(
                    ("devices", "gripper", "device_id"),
                    f"device id {jaw.params['device_id']} is the arm joint {ids[jaw.params['device_id']]}'s",
                )
            )


def _check_shared_nodes(src: Located, devices: dict[str, DeviceConfig], issues: list[ConfigIssue]) -> None:
    """A node ID may serve one drive per bus only (arm joints and gripper motors share the bus)."""
    seen: dict[tuple[str | None, int], str] = {}  # (bus, node ID) -> role
    for role, dev in devices.items():
        if not dev.driver.startswith("canopen_"):
            continue
        entries = dev.params.get("joints") or list((dev.params.get("motors") or {}).values())
        key_name = "joints" if dev.driver == "canopen_arm" else "motors"
        for i, item in enumerate(entries):
            nid = item.get("node_id")
            if nid is None:
                continue
            key = (dev.params.get("bus"), nid)
            if key in seen and seen[key] != role:
                sub = i if key_name == "joints" else list(dev.params["motors"])[i]
                issues.append(
                    src.issue(
                        ("devices", role, key_name, sub, "node_id"),
                        f"node ID {nid} is already used by the {seen[key]} on bus `{key[0]}`",
                    )
                )
            seen.setdefault(key, role)


def _check_unique_nodes(src: Located, path: PathT, ids: list, host_id: int | None, issues: list[ConfigIssue]) -> None:
    seen: set = set()
    for nid in ids:
        if nid is not None and nid in seen:
            issues.append(src.issue(path, f"node ID {nid} used twice"))
        if nid is not None and nid == host_id:
            issues.append(src.issue(path, f"node ID {nid} is the bus's host_node_id (this computer's heartbeat)"))
        seen.add(nid)


def validate_hal_config(src: Located) -> HalConfig:
    """Validate parsed YAML into a :class:`HalConfig`; raise ConfigError with all issues."""
    issues: list[ConfigIssue] = []
    data = src.data
    base = Path(src.file).resolve().parent
    if not isinstance(data, dict):
        raise ConfigError([src.issue((), "a HAL config must be a mapping with `devices`")])
    issues.extend(unknown_keys(src, data, (), ("buses", "devices", "sim", "model", "actions")))
    buses: dict[str, BusConfig] = {}
    raw_buses = data.get("buses") or {}
    if not isinstance(raw_buses, dict):
        issues.append(src.issue(("buses",), "expected a mapping of bus name -> settings"))
        raw_buses = {}
    for name, raw in raw_buses.items():
        p = _check_mapping(src, ("buses", name), raw, BUS_SCHEMA, base, issues)
        opts = {
            k: v
            for k, v in p.items()
            if k not in ("interface", "channel", "host_node_id", "sync_period") and v is not None
        }
        if p.get("interface") == "udp_multicast" and p.get("hop_limit") is None:
            opts["hop_limit"] = 0  # never let simulated CAN frames leave this machine by default
        buses[str(name)] = BusConfig(
            str(name),
            p.get("interface") or "",
            str(p.get("channel") or ""),
            opts,
            src.mark(("buses", name)),
            p.get("host_node_id") or 127,
            p.get("sync_period"),
        )
    devices: dict[str, DeviceConfig] = {}
    raw_devices = data.get("devices")
    if not isinstance(raw_devices, dict):
        issues.append(src.issue(("devices",), "missing or invalid `devices` mapping (role -> driver settings)"))
        raw_devices = {}
    for role, raw in raw_devices.items():
        if role not in ROLES:
            issues.append(
                src.issue(
                    ("devices", role), f"unknown role `{role}`{suggest(str(role), ROLES)}; roles: {', '.join(ROLES)}"
                )
            )
            continue
        dev = _check_device(src, role, raw, base, buses, issues)
        if dev is not None:
            devices[role] = dev
    _check_shared_nodes(src, devices, issues)
    _check_reach(src, devices, issues)
    _check_simulated_operators(src, devices, issues)
    for role in REQUIRED_ROLES:
        if isinstance(data.get("devices"), dict) and role not in raw_devices:
            issues.append(src.issue(("devices",), f"missing required role `{role}`"))
    scenario = None
    follow_vehicle = False
    sim = data.get("sim")
    if sim is not None:
        sim_p = _check_mapping(
            src,
            ("sim",),
            sim,
            {
                "scenario": Param("str", None),
                "follow_vehicle": Param(
                    "bool", False, doc="the simulated vehicle follows the real one's navigation (hal.mixed)"
                ),
            },
            base,
            issues,
        )
        scenario = sim_p.get("scenario")
        follow_vehicle = bool(sim_p.get("follow_vehicle"))
    rig = _check_mapping(
        src,
        (),
        {k: data.get(k) for k in ("model", "actions")},
        {"model": Param("path", None), "actions": Param("path", None)},
        base,
        issues,
    )
    if issues:
        raise ConfigError(issues)
    return HalConfig(
        path=src.file,
        devices=devices,
        buses=buses,
        scenario=scenario,
        follow_vehicle=follow_vehicle,
        model=rig.get("model"),
        actions=rig.get("actions"),
        model_mark=src.mark(("model",)) if data.get("model") is not None else None,
        actions_mark=src.mark(("actions",)) if data.get("actions") is not None else None,
    )


def load_hal_config(path: str | Path) -> HalConfig:
    """Read and validate a HAL config file (raises ConfigError on any problem)."""
    return validate_hal_config(load_yaml(path))
