"""HAL configuration files: which driver serves each device role, with its parameters.

A HAL config is user-written YAML (see ``hal/configs/``)::

    buses:                      # optional: CAN buses shared by CANopen devices
      can0: {interface: socketcan, channel: can0, bitrate: 1000000}
    devices:                    # role -> driver + parameters
      vehicle: {driver: ardusub, url: "udpin:0.0.0.0:14550", ...}
      arm:     {driver: canopen_arm, bus: can0, eds: ../data/cia402_minimal.eds, joints: [...]}
    sim:                        # only for driver "sim"
      scenario: pipe_recovery

:func:`load_hal_config` checks everything at once and raises
:class:`maris_common.yamlsrc.ConfigError` naming ``file:line:column`` and the field,
with did-you-mean suggestions for typos. Relative paths (EDS files) are resolved
against the config file's folder. The per-driver parameter schemas live in
:data:`DRIVER_SCHEMAS`; a new driver adds its schema there and its builder in
:mod:`hal.factory`.
"""

from __future__ import annotations

import copy
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable

from maris_common.yamlsrc import ConfigError, ConfigIssue, Located, Mark, PathT, load_yaml, suggest, unknown_keys

#: Device roles a HAL config may fill (same names as :meth:`hal.interfaces.DeviceSet.by_role`).
ROLES: tuple[str, ...] = ("vehicle", "arm", "gripper", "detector", "wrench_sensor")
#: ArduSub flight modes (custom_mode names).
SUB_MODES: tuple[str, ...] = ("STABILIZE", "ACRO", "ALT_HOLD", "AUTO", "GUIDED", "CIRCLE", "SURFACE", "POSHOLD", "MANUAL")
#: Roles every backend must have.
REQUIRED_ROLES: tuple[str, ...] = ("vehicle", "arm")


# --------------------------------------------------------------------------- schema


@dataclass(frozen=True)
class Param:
    """One driver parameter: expected kind, default (``REQUIRED`` if none), extra check.

    kind: "str", "int", "float", "bool", "path", "list", "map" (name -> item),
    "record" (one mapping with fixed keys), or a tuple of allowed strings.
    ``check(value) -> error text or None``. ``item`` is the schema of list items,
    of map values, or of the record itself.
    """

    kind: Any
    default: Any = None
    required: bool = False
    check: Callable[[Any], str | None] | None = None
    item: dict[str, "Param"] | None = None
    doc: str = ""


def _positive(v: Any) -> str | None:
    return None if v > 0 else "must be > 0"


#: ArduSub sends its HEARTBEAT at 1 Hz (GCS_MAVLink: the heartbeat's stream period)
ARDUSUB_HEARTBEAT_PERIOD_S = 1.0


def _ardusub_heartbeat_timeout(v: Any) -> str | None:
    """A lost-link limit below two heartbeat periods faults the link on ordinary jitter
    (every late heartbeat) and re-requests the telemetry streams each time."""
    limit = 2.0 * ARDUSUB_HEARTBEAT_PERIOD_S
    return None if v >= limit else f"must be at least {limit:g} s (ArduSub sends HEARTBEAT at 1 Hz)"


def _non_negative(v: Any) -> str | None:
    return None if v >= 0 else "must be >= 0"


def _node_id(v: Any) -> str | None:
    return None if 1 <= v <= 127 else "CANopen node ID must be in 1..127"


def _port(v: Any) -> str | None:
    return None if 1 <= v <= 65535 else "TCP port must be in 1..65535"


def _mavlink_url(v: Any) -> str | None:
    prefixes = ("udpin:", "udpout:", "udp:", "tcp:", "tcpin:", "/dev/", "COM", "serial:")
    text = str(v)
    if not text.startswith(prefixes):
        return "MAVLink URL must look like udpin:HOST:PORT, tcp:HOST:PORT or /dev/ttyXXX"
    if text.startswith(("udpin:", "udpout:", "udp:", "tcp:", "tcpin:")):
        port = text.rpartition(":")[2]
        if not port.isdigit() or not 1 <= int(port) <= 65535:
            return f"MAVLink URL port must be a number in 1..65535, got `{port}`"
    return None


def _host_heartbeat_timeout(v: Any) -> str | None:
    # the drive stores ms in 16 bits; it must outlast a few of our heartbeats (hal.drivers.canbus.HOST_HEARTBEAT_PERIOD)
    if v == 0 or 0.1 <= v <= 65.535:
        return None
    return "must be 0 (drives do not watch this computer) or in 0.1..65.535 s (at least twice our 0.05 s heartbeat)"


def _dofs(v: Any) -> str | None:
    if not (isinstance(v, list) and len(v) == 6 and all(isinstance(x, bool) for x in v)):
        return "must be a list of 6 booleans (surge, sway, heave, roll, pitch, yaw)"
    return None


_DRIVE = {
    "node_id": Param("int", required=True, check=_node_id, doc="CANopen node ID"),
    "counts_per_rad": Param("float", 4096 / 6.283185307179586, check=_positive, doc="position units per rad at the joint"),
    "velocity_units_per_rad_s": Param("float", 1000.0, check=_positive, doc="0x60FF/0x606C units per rad/s at the joint"),
    "max_velocity": Param("float", 1.0, check=_positive, doc="rad/s, references are clipped to this"),
}
_JOINT = {"name": Param("str", required=True), **_DRIVE}

_CANOPEN_COMMON = {
    "bus": Param("str", required=True, doc="name of an entry under `buses`"),
    "eds": Param("path", required=True, doc="vendor EDS/DCF file of the drives"),
    "heartbeat_period": Param("float", 0.05, check=_positive, doc="s, producer heartbeat asked of each drive"),
    "heartbeat_timeout": Param("float", 0.3, check=_positive, doc="s, a drive silent this long is faulted"),
    "pdo_period": Param("float", 0.01, check=_positive, doc="s, event timer of the drives' TPDOs"),
    "stale_timeout": Param("float", 0.2, check=_positive, doc="s, TPDO data older than this is a fault"),
    "host_heartbeat_timeout": Param("float", 0.5, check=_host_heartbeat_timeout,
                                    doc="s, drives fault without our heartbeat (0: off); bounds how long they run on after a crash"),
    "transmission": Param(("auto", "event_timer", "on_change", "sync"), "auto",
                          doc="how the drives send their TPDOs (auto: event timer if the EDS has one, else sync/on change)"),
    "rated_current_a": Param("float", None, check=_positive, doc="A, motor rated current when the EDS has no 0x6075"),
}

def _angle_map(v: Any) -> str | None:
    ok = all(isinstance(k, str) and isinstance(x, (int, float)) and not isinstance(x, bool) and x == x and abs(x) < 1e3 for k, x in v.items())
    return None if ok and v else "must map preshape names to palm angles in rad, e.g. {cylindrical: 0.0, parallel: 0.6}"


def _rpy(v: Any) -> str | None:
    ok = isinstance(v, list) and len(v) == 3 and all(isinstance(x, (int, float)) and not isinstance(x, bool) for x in v)
    return None if ok else "must be a list of 3 angles [roll, pitch, yaw] in rad"


def _baro_instance(v: Any) -> str | None:
    return None if 0 <= v <= 3 else "must be 0 (auto) or a baro instance 1..3"


_FULL_STICK = {
    "surge_mps": Param("float", required=True, check=_positive, doc="m/s reached at full forward stick"),
    "sway_mps": Param("float", required=True, check=_positive, doc="m/s reached at full lateral stick"),
    "heave_mps": Param("float", required=True, check=_positive, doc="m/s reached at full throttle stick"),
    "yaw_rad_s": Param("float", required=True, check=_positive, doc="rad/s reached at full yaw stick"),
}

_SERIAL_OR_TCP = {
    "transport": Param(("tcp", "serial"), "tcp"),
    "host": Param("str", "192.168.194.95"),
    "port": Param("int", 16171, check=_port),
    "device": Param("str", None, doc="serial device, e.g. /dev/ttyUSB0"),
    "baudrate": Param("int", 115200, check=_positive),
    "timeout": Param("float", 0.5, check=_positive, doc="s without a valid message before FAULT"),
    "mounting_rpy": Param("list", [0.0, 0.0, 0.0], check=_rpy, doc="rad, sensor axes relative to the vehicle frame"),
}

def _hue(v: Any) -> str | None:
    ok = isinstance(v, list) and len(v) == 2 and all(isinstance(x, int) and not isinstance(x, bool) and 0 <= x <= 179 for x in v)
    return None if ok else "must be [low, high] hues on OpenCV's 0-179 scale (low > high wraps around red), e.g. [22, 35]"


def _byte(v: Any) -> str | None:
    return None if 0 <= v <= 255 else "must be within 0-255 (OpenCV's saturation/value scale)"


_CAMERA = {
    "source": Param("str", required=True, doc="device (0, /dev/video0), URL (rtsp://, http://), GStreamer pipeline (with `!`), video file or image folder"),
    "backend": Param(("auto", "v4l2", "ffmpeg", "gstreamer", "images"), "auto", doc="how to open `source`; auto guesses from its form"),
    "width": Param("int", None, check=_positive, doc="px, asked of V4L2 devices"),
    "height": Param("int", None, check=_positive, doc="px, asked of V4L2 devices"),
    "fps": Param("float", None, check=_positive, doc="frames per second (asked of devices; the replay rate of files and folders)"),
    "loop": Param("bool", False, doc="files and folders: start again at the end"),
}

#: Parameters of each driver, and the roles it may serve.
DRIVER_SCHEMAS: dict[str, tuple[tuple[str, ...], dict[str, Param]]] = {
    "sim": (ROLES, {}),
    "ardusub": (
        ("vehicle",),
        {
            "url": Param("str", required=True, check=_mavlink_url, doc="pymavlink connection string"),
            "baudrate": Param("int", 115200, check=_positive),
            "source_system": Param("int", 255, check=_positive),
            "target_system": Param("int", 1, check=_positive),
            "heartbeat_timeout": Param("float", 3.0, check=_ardusub_heartbeat_timeout, doc="s, lost-link limit (>= 2 s)"),
            "telemetry_timeout": Param("float", 1.0, check=_positive, doc="s, stale attitude/position limit"),
            "arm_mode": Param(SUB_MODES, "GUIDED", doc="ArduSub mode set (and confirmed) before arming"),
            "arm_timeout": Param("float", 5.0, check=_positive, doc="s to wait for each confirmation (mode, arming)"),
            "command": Param(("setpoint", "manual_control"), "setpoint",
                             doc="setpoint: SET_POSITION_TARGET_LOCAL_NED velocities (GUIDED, needs a position estimate); "
                                 "manual_control: open-loop MANUAL_CONTROL sticks (thrust), needs manual_full_stick"),
            "manual_full_stick": Param("record", None, item=_FULL_STICK,
                                       doc="measured speeds at full stick (manual_control only): stick = reference / these"),
            "depth_sensor": Param("int", 0, check=_baro_instance,
                                  doc="baro instance of the depth sensor: 1-3 (SCALED_PRESSURE[n]); 0 = the highest reported"),
            "max_speed": Param("float", 1.0, check=_positive, doc="m/s clip on linear references (also bounds plausible DVL speeds)"),
            "max_acceleration": Param("float", 1.0, check=_positive, doc="m/s^2 the vehicle can reach (bounds plausible DVL changes)"),
            "max_yaw_rate": Param("float", 0.5, check=_positive, doc="rad/s clip"),
            "actuated_dofs": Param("list", [True, True, True, False, False, True], check=_dofs),
            "dvl": Param("record", None, item=_SERIAL_OR_TCP, doc="Water Linked DVL for body velocity"),
            "ahrs": Param("record", None, item={**_SERIAL_OR_TCP, "transport": Param(("serial",), "serial")}, doc="MicroStrain AHRS"),
        },
    ),
    "canopen_arm": (("arm",), {**_CANOPEN_COMMON, "joints": Param("list", required=True, item=_JOINT)}),
    "stereo_pipe_detector": (
        ("detector",),
        {
            "calibration": Param("path", required=True, doc="OpenCV FileStorage stereo calibration, or a ROS camera_info file of the left camera"),
            "calibration_right": Param("path", None, doc="ROS camera_info of the right camera (or OpenCV's extrinsics file)"),
            "left": Param("record", None, item=_CAMERA, doc="left camera (the URDF's stereo_camera frame)"),
            "right": Param("record", None, item=_CAMERA, doc="right camera"),
            "side_by_side": Param("record", None, item=_CAMERA, doc="one source delivering left|right side by side, instead of left + right"),
            "sync": Param(("time", "sequence"), "time", doc="pair frames by grab time (live cameras) or frame number (recordings)"),
            "pairing_tolerance_s": Param("float", 0.02, check=_positive, doc="s, largest time between the two frames of a pair"),
            "stale_timeout_s": Param("float", 0.5, check=_positive, doc="s without a frame before a camera is faulted"),
            "rate_hz": Param("float", 10.0, check=_positive, doc="detections per second (MARIS: about 10)"),
            "hsv": Param("record", None, item={"hue": Param("list", [22, 35], check=_hue), "sat_min": Param("int", 63, check=_byte),
                                                  "val_min": Param("int", 30, check=_byte)}, doc="colour thresholds (OpenCV HSV scales)"),
            "pipe": Param("record", None, item={"radius_m": Param("float", 0.05, check=_positive), "length_m": Param("float", 1.0, check=_positive),
                                                  "grasp_from_end_m": Param("float", None, check=_non_negative)},
                          doc="target size; grasp frame origin this far from the visible end (default: the centre)"),
            "arm_mask": Param("record", None, item={"link_radius_m": Param("float", 0.07, check=_positive),
                                                      "hand_radius_m": Param("float", 0.10, check=_positive),
                                                      "margin_px": Param("int", 4, check=_non_negative)}, doc="arm drawn out of the images"),
            "urdf": Param("path", None, doc="UVMS model for the arm mask and the camera mounting (default: the shipped one)"),
            "log_frames_hz": Param("float", 1.0, check=_non_negative, doc="left camera frames (JPEG) written to the run log"),
            "threads": Param("int", 1, check=_positive, doc="OpenCV threads of the detector"),
        },
    ),
    "canopen_gripper": (
        ("gripper",),
        {
            **_CANOPEN_COMMON,
            "motors": Param("map", required=True, item=_DRIVE, doc="group name -> drive (distal, proximal, palm)"),
            "preshapes": Param("map", {"cylindrical": 0.0}, check=_angle_map, doc="preshape name -> palm group position, rad"),
            "close_velocity": Param("float", 0.5, check=_positive, doc="rad/s of finger groups while closing"),
            "open_position": Param("float", 0.0, doc="rad of finger groups when open"),
        },
    ),
}

_BUS = {
    "interface": Param("str", required=True, doc="python-can interface: socketcan, pcan, udp_multicast, ..."),
    "channel": Param("str", required=True),
    "bitrate": Param("int", None, check=_positive),
    "port": Param("int", None, check=_port, doc="udp_multicast only"),
    "hop_limit": Param("int", None, check=_non_negative, doc="udp_multicast only; 0 keeps frames on this host"),
    "host_node_id": Param("int", 127, check=_node_id, doc="node ID of this computer's heartbeat on the bus"),
    "sync_period": Param("float", None, check=_positive, doc="s, this computer sends SYNC at this period (for `transmission: sync`)"),
}

#: Keys that were accepted once and are now refused with an explanation.
_RETIRED = {
    ("canopen_gripper", "current_scale"): "`current_scale` was never used: motor currents are 0x6078 per mille of the rated "
                                          "current (0x6075, or `rated_current_a` when the EDS lacks it); remove it",
}


# --------------------------------------------------------------------------- result


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

    @property
    def roles(self) -> frozenset[str]:
        """Roles present in the file (e.g. {"vehicle", "arm", "gripper"})."""
        return frozenset(self.devices)

    @property
    def is_sim(self) -> bool:
        return all(d.driver == "sim" for d in self.devices.values())


# --------------------------------------------------------------------------- validation


_KIND_TYPES = {"str": (str,), "int": (int,), "float": (int, float), "bool": (bool,), "path": (str,), "map": (dict,),
               "record": (dict,), "list": (list,)}


def _check_value(src: Located, path: PathT, spec: Param, value: Any, base: Path, issues: list[ConfigIssue]) -> Any:
    kind = spec.kind
    if isinstance(kind, tuple):
        if value not in kind:
            issues.append(src.issue(path, f"must be one of {', '.join(kind)}, got {value!r}{suggest(str(value), kind)}"))
            return None
        return value
    types = _KIND_TYPES[kind]
    if isinstance(value, bool) and kind in ("int", "float") or not isinstance(value, types):
        issues.append(src.issue(path, f"expected {kind}, got {type(value).__name__} {value!r}"))
        return None
    if kind == "float":
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


def _check_mapping(src: Located, path: PathT, data: Any, schema: dict[str, Param], base: Path, issues: list[ConfigIssue]) -> dict[str, Any]:
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


def _check_device(src: Located, role: str, data: Any, base: Path, buses: dict, issues: list[ConfigIssue]) -> DeviceConfig | None:
    path: PathT = ("devices", role)
    if not isinstance(data, dict):
        issues.append(src.issue(path, "expected a mapping with at least `driver`"))
        return None
    driver = data.get("driver")
    if not isinstance(driver, str) or driver not in DRIVER_SCHEMAS:
        where = path + ("driver",) if "driver" in data else path
        what = f"unknown driver `{driver}`{suggest(str(driver), DRIVER_SCHEMAS)}" if driver is not None else "missing required field `driver`"
        issues.append(src.issue(where, f"{what}; known drivers: {', '.join(sorted(DRIVER_SCHEMAS))}"))
        return None
    allowed_roles, schema = DRIVER_SCHEMAS[driver]
    if role not in allowed_roles:
        issues.append(src.issue(path + ("driver",), f"driver `{driver}` cannot serve role `{role}` (it serves {', '.join(allowed_roles)})"))
        return None
    retired = {k for k in data if (driver, k) in _RETIRED}
    issues.extend(src.issue(path + (k,), _RETIRED[(driver, k)]) for k in sorted(retired))
    params = _check_mapping(src, path, {k: v for k, v in data.items() if k != "driver" and k not in retired}, schema, base, issues)
    if "bus" in schema and params.get("bus") is not None and params["bus"] not in buses:
        issues.append(src.issue(path + ("bus",), f"unknown bus `{params['bus']}`{suggest(params['bus'], buses)}; define it under `buses`"))
    if driver == "ardusub" and params.get("command") == "setpoint" and params.get("arm_mode") not in (None, "GUIDED"):
        issues.append(src.issue(path + ("arm_mode",), "velocity setpoints are only followed in GUIDED; use arm_mode: GUIDED or command: manual_control"))
    if driver == "ardusub" and params.get("command") == "manual_control":
        if params.get("arm_mode") not in ("MANUAL", "STABILIZE", "ALT_HOLD", "ACRO"):
            issues.append(src.issue(path + ("arm_mode",), "MANUAL_CONTROL sticks need a pilot mode: MANUAL, STABILIZE, ALT_HOLD or ACRO"))
        if not params.get("manual_full_stick") and "manual_full_stick" not in data:
            issues.append(src.issue(path, "command: manual_control is open loop (sticks are thrust, not velocity): give "
                                          "`manual_full_stick: {surge_mps, sway_mps, heave_mps, yaw_rad_s}`, the speeds "
                                          "measured at full stick on this vehicle (see docs/field.md)"))
    for sensor in ("dvl", "ahrs"):
        cfg = params.get(sensor)
        if cfg and cfg.get("transport") == "serial" and not cfg.get("device"):
            issues.append(src.issue(path + (sensor,), "serial transport needs `device` (e.g. /dev/ttyUSB0)"))
    if driver == "stereo_pipe_detector":
        _check_cameras(src, path, params, base, issues)
    host_id = buses[params["bus"]].host_node_id if params.get("bus") in buses else None
    if driver == "canopen_arm" and params.get("joints"):
        _check_unique_nodes(src, path + ("joints",), [j.get("node_id") for j in params["joints"]], host_id, issues)
    if driver == "canopen_gripper" and params.get("motors"):
        _check_unique_nodes(src, path + ("motors",), [m.get("node_id") for m in params["motors"].values()], host_id, issues)
    if driver.startswith("canopen_"):
        _check_canopen_timing(src, path, params, buses.get(params.get("bus")), issues)
    return DeviceConfig(role, driver, params, src.mark(path))


def _check_cameras(src: Located, path: PathT, params: dict, base: Path, issues: list[ConfigIssue]) -> None:
    """Either `left` + `right` or `side_by_side`; file and folder sources exist
    (made absolute against the config's folder)."""
    if params.get("calibration"):
        try:
            from vision.calibration import load_stereo_calibration

            load_stereo_calibration(params["calibration"], params.get("calibration_right"))
        except ConfigError as exc:
            issues.extend(exc.issues)
    pair, sbs = params.get("left") is not None or params.get("right") is not None, params.get("side_by_side") is not None
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
            issues.append(src.issue(path + (name, "source"), f"camera source not found: {p} (a file or folder; or a device, URL or GStreamer pipeline)"))
        else:
            cam["source"] = str(p.resolve())

def _check_canopen_timing(src: Located, path: PathT, p: dict, bus: "BusConfig | None", issues: list[ConfigIssue]) -> None:
    """Timing settings of CANopen drives that only make sense together."""
    hb, hb_to, stale = p.get("heartbeat_period"), p.get("heartbeat_timeout"), p.get("stale_timeout")
    if hb and hb_to and hb_to < 2 * hb:
        issues.append(src.issue(path + ("heartbeat_timeout",), f"must be at least twice heartbeat_period ({hb:g} s)"))
    sync = bus.sync_period if bus is not None else None
    if p.get("transmission") == "sync":
        if not sync:
            issues.append(src.issue(path + ("transmission",), f"`sync` needs a SYNC producer: set `sync_period` on bus `{p.get('bus')}`"))
        elif stale and stale < 2 * sync:
            issues.append(src.issue(path + ("stale_timeout",), f"must be at least twice the bus sync_period ({sync:g} s)"))
    if p.get("transmission") == "event_timer" and stale and p.get("pdo_period") and stale < 2 * p["pdo_period"]:
        issues.append(src.issue(path + ("stale_timeout",), f"must be at least twice pdo_period ({p['pdo_period']:g} s)"))


def _check_shared_nodes(src: Located, devices: dict[str, "DeviceConfig"], issues: list[ConfigIssue]) -> None:
    """A node ID may serve one drive per bus only (arm joints and gripper motors share the bus)."""
    seen: dict[tuple[str, int], str] = {}
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
                issues.append(src.issue(("devices", role, key_name, sub, "node_id"),
                                        f"node ID {nid} is already used by the {seen[key]} on bus `{key[0]}`"))
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
    issues.extend(unknown_keys(src, data, (), ("buses", "devices", "sim")))
    buses: dict[str, BusConfig] = {}
    raw_buses = data.get("buses") or {}
    if not isinstance(raw_buses, dict):
        issues.append(src.issue(("buses",), "expected a mapping of bus name -> settings"))
        raw_buses = {}
    for name, raw in raw_buses.items():
        p = _check_mapping(src, ("buses", name), raw, _BUS, base, issues)
        opts = {k: v for k, v in p.items() if k not in ("interface", "channel", "host_node_id", "sync_period") and v is not None}
        if p.get("interface") == "udp_multicast" and p.get("hop_limit") is None:
            opts["hop_limit"] = 0  # never let simulated CAN frames leave this machine by default
        buses[str(name)] = BusConfig(str(name), p.get("interface") or "", str(p.get("channel") or ""), opts,
                                     src.mark(("buses", name)), p.get("host_node_id") or 127, p.get("sync_period"))
    devices: dict[str, DeviceConfig] = {}
    raw_devices = data.get("devices")
    if not isinstance(raw_devices, dict):
        issues.append(src.issue(("devices",), "missing or invalid `devices` mapping (role -> driver settings)"))
        raw_devices = {}
    for role, raw in raw_devices.items():
        if role not in ROLES:
            issues.append(src.issue(("devices", role), f"unknown role `{role}`{suggest(str(role), ROLES)}; roles: {', '.join(ROLES)}"))
            continue
        dev = _check_device(src, role, raw, base, buses, issues)
        if dev is not None:
            devices[role] = dev
    _check_shared_nodes(src, devices, issues)
    for role in REQUIRED_ROLES:
        if isinstance(data.get("devices"), dict) and role not in raw_devices:
            issues.append(src.issue(("devices",), f"missing required role `{role}`"))
    scenario = None
    sim = data.get("sim")
    if sim is not None:
        sim_p = _check_mapping(src, ("sim",), sim, {"scenario": Param("str", None)}, base, issues)
        scenario = sim_p.get("scenario")
    if issues:
        raise ConfigError(issues)
    return HalConfig(path=src.file, devices=devices, buses=buses, scenario=scenario)


def load_hal_config(path: str | Path) -> HalConfig:
    """Read and validate a HAL config file (raises ConfigError on any problem)."""
    return validate_hal_config(load_yaml(path))
