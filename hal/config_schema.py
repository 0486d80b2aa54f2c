"""Parameter schemas of the HAL configuration: one :class:`Param` per driver parameter.

:data:`DRIVER_SCHEMAS` maps each driver name to the roles it may fill and its
parameters (kind, default, extra check, units in ``doc``); :data:`BUS_SCHEMA` is
the schema of a CAN bus entry. :mod:`hal.config` validates a user's file against
them. A new driver adds its schema here and its builder in :mod:`hal.factory`.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

#: Operator input roles (:class:`hal.interfaces.OperatorInput`): a gamepad, the Foxglove
#: live view, the terminal's keyboard.
OPERATOR_ROLES: tuple[str, ...] = ("gamepad", "foxglove", "keyboard")
#: Device roles a HAL config may fill (same names as :meth:`hal.interfaces.DeviceSet.by_role`).
ROLES: tuple[str, ...] = ("vehicle", "arm", "gripper", "detector", "wrench_sensor") + OPERATOR_ROLES
#: ArduSub flight modes (custom_mode names).
SUB_MODES: tuple[str, ...] = (
    "STABILIZE",
    "ACRO",
    "ALT_HOLD",
    "AUTO",
    "GUIDED",
    "CIRCLE",
    "SURFACE",
    "POSHOLD",
    "MANUAL",
)
#: Roles every backend must have.
REQUIRED_ROLES: tuple[str, ...] = ("vehicle", "arm")


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
    item: dict[str, Param] | None = None
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
    "counts_per_rad": Param(
        "float", 4096 / 6.283185307179586, check=_positive, doc="position units per rad at the joint"
    ),
    "velocity_units_per_rad_s": Param(
        "float", 1000.0, check=_positive, doc="0x60FF/0x606C units per rad/s at the joint"
    ),
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
    "host_heartbeat_timeout": Param(
        "float",
        0.5,
        check=_host_heartbeat_timeout,
        doc="s, drives fault without our heartbeat (0: off); bounds how long they run on after a crash",
    ),
    "transmission": Param(
        ("auto", "event_timer", "on_change", "sync"),
        "auto",
        doc="how the drives send their TPDOs (auto: event timer if the EDS has one, else sync/on change)",
    ),
    "rated_current_a": Param("float", None, check=_positive, doc="A, motor rated current when the EDS has no 0x6075"),
}


def _angle_map(v: Any) -> str | None:
    ok = all(
        isinstance(k, str) and isinstance(x, (int, float)) and not isinstance(x, bool) and x == x and abs(x) < 1e3
        for k, x in v.items()
    )
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


_PING = {
    "transport": Param(("serial", "udp"), "serial"),
    "device": Param("str", None, doc="serial device, e.g. /dev/ttyUSB1"),
    "baudrate": Param("int", 115200, check=_positive),
    "host": Param("str", None, doc="udp: the sonar's address (BlueOS ping UDP bridge, e.g. 192.168.2.2)"),
    "port": Param("int", 9090, check=_port),
    "rate_hz": Param("float", 10.0, check=_positive, doc="distance requests per second"),
    "timeout": Param("float", 1.0, check=_positive, doc="s without a new confident measurement: altitude unknown"),
    "min_confidence": Param("int", 50, check=lambda v: None if 0 <= v <= 100 else "must be within 0-100 (%)", doc="%"),
    "offset_m": Param(
        "float", 0.0, doc="m added to the distance: the transducer's height above the altitude reference"
    ),
    "speed_of_sound_mps": Param("float", None, check=_positive, doc="m/s set at start (sea water ~1500)"),
}


def _hue(v: Any) -> str | None:
    ok = (
        isinstance(v, list)
        and len(v) == 2
        and all(isinstance(x, int) and not isinstance(x, bool) and 0 <= x <= 179 for x in v)
    )
    return (
        None if ok else "must be [low, high] hues on OpenCV's 0-179 scale (low > high wraps around red), e.g. [22, 35]"
    )


def _byte(v: Any) -> str | None:
    return None if 0 <= v <= 255 else "must be within 0-255 (OpenCV's saturation/value scale)"


_CAMERA = {
    "source": Param(
        "str",
        required=True,
        doc="device (0, /dev/video0), URL (rtsp://, http://), GStreamer pipeline (with `!`), video file or image folder",
    ),
    "backend": Param(
        ("auto", "v4l2", "ffmpeg", "gstreamer", "images"),
        "auto",
        doc="how to open `source`; auto guesses from its form",
    ),
    "width": Param("int", None, check=_positive, doc="px, asked of V4L2 devices"),
    "height": Param("int", None, check=_positive, doc="px, asked of V4L2 devices"),
    "fps": Param(
        "float", None, check=_positive, doc="frames per second (asked of devices; the replay rate of files and folders)"
    ),
    "loop": Param("bool", False, doc="files and folders: start again at the end"),
}


def _fraction_below_one(v: Any) -> str | None:
    return None if 0.0 <= v < 1.0 else "must be within 0 (inclusive) and 1 (exclusive)"


def _reach_device_id(v: Any) -> str | None:
    return None if 1 <= v <= 0xFE else "Reach device id must be in 1..254 (0xFF addresses every device)"


def _heartbeat_hz(v: Any) -> str | None:
    return None if 1 <= v <= 255 else "the arm streams at 1..255 Hz (one byte, HEARTBEAT_FREQUENCY)"


def _sign(v: Any) -> str | None:
    return None if v in (1, -1) else "must be 1 or -1"


#: The link to a Reach arm (shared by its joints and its jaw).
_REACH_LINK = {
    "transport": Param(("serial", "udp"), required=True, doc="serial (RS-232/RS-485 adapter) or udp (Bravo Ethernet)"),
    "device": Param("str", None, doc="serial device, e.g. /dev/ttyUSB0 (serial)"),
    "baudrate": Param("int", 115200, check=_positive, doc="serial line rate (the arms' default 115200)"),
    "host": Param("str", None, doc="the arm's address (udp), e.g. 192.168.2.3"),
    "port": Param("int", 6789, check=_port, doc="the arm's UDP port (udp)"),
    "local_port": Param("int", 0, check=lambda v: None if 0 <= v <= 65535 else "must be in 0..65535", doc="0: any"),
    "guardian": Param(
        "bool", True, doc="a separate process stops the arm when this one dies or stalls (see docs/faults.md)"
    ),
    "guard_timeout": Param(
        "float", 0.5, check=_positive, doc="s without a command to an enabled arm before the guardian stops it"
    ),
}
_REACH_FEEDBACK = {
    "feedback_rate_hz": Param(
        "int",
        20,
        check=_heartbeat_hz,
        doc="Hz, position/velocity/current heartbeat of each device (serial: mind the line load, docs/field.md)",
    ),
    "status_period": Param("float", 0.5, check=_positive, doc="s between requests of mode and status flags"),
    "stale_timeout": Param("float", 0.2, check=_positive, doc="s, readings older than this fault the device"),
}
_REACH_JOINT = {
    "name": Param("str", required=True, doc="the URDF joint's name"),
    "device_id": Param("int", required=True, check=_reach_device_id, doc="Alpha 5: 0x05 base .. 0x02 wrist"),
    "max_velocity": Param("float", 0.5, check=_positive, doc="rad/s, demands are clipped to this"),
    "offset": Param("float", 0.0, doc="rad, URDF angle = sign x device position + offset"),
    "sign": Param("int", 1, check=_sign),
}


#: Parameters of both pipe detectors (stereo and one camera).
_DETECTOR_COMMON = {
    "rate_hz": Param("float", 10.0, check=_positive, doc="detections per second (MARIS: about 10)"),
    "hsv": Param(
        "record",
        None,
        item={
            "hue": Param("list", [22, 35], check=_hue),
            "sat_min": Param("int", 63, check=_byte),
            "val_min": Param("int", 30, check=_byte),
        },
        doc="colour thresholds (OpenCV HSV scales)",
    ),
    "pipe": Param(
        "record",
        None,
        item={
            "radius_m": Param("float", 0.05, check=_positive),
            "length_m": Param("float", 1.0, check=_positive),
            "grasp_from_end_m": Param("float", None, check=_non_negative),
        },
        doc="target size; grasp frame origin this far from the visible end (default: the centre)",
    ),
    "arm_mask": Param(
        "record",
        None,
        item={
            "link_radius_m": Param("float", 0.07, check=_positive),
            "hand_radius_m": Param("float", 0.10, check=_positive),
            "margin_px": Param("int", 4, check=_non_negative),
        },
        doc="arm drawn out of the images",
    ),
    "min_reported_confidence": Param(
        "float",
        0.2,
        check=_fraction_below_one,
        doc="answers less sure than this are reported as no pipe (docs/vision.md, error versus confidence)",
    ),
    "urdf": Param("path", None, doc="UVMS model for the arm mask and the camera mounting (default: the shipped one)"),
    "log_frames_hz": Param("float", 1.0, check=_non_negative, doc="left camera frames (JPEG) written to the run log"),
    "threads": Param("int", 1, check=_positive, doc="OpenCV threads of the detector"),
}
_CAMERA_MODEL = {
    "width": Param("int", required=True, check=_positive, doc="px"),
    "height": Param("int", required=True, check=_positive, doc="px"),
    "fx": Param("float", required=True, check=_positive, doc="px"),
    "fy": Param("float", required=True, check=_positive, doc="px"),
    "cx": Param("float", required=True, doc="px"),
    "cy": Param("float", required=True, doc="px"),
    "distortion": Param("list", [], doc="OpenCV k1 k2 p1 p2 [k3]"),
}
_RTP_STREAM = {
    "port": Param("int", 5600, check=_positive, doc="UDP port the stream arrives on (BlueOS: 5600)"),
    "bind": Param("str", "0.0.0.0", doc="address of this computer to listen on (default: all)"),
    "payload_type": Param("int", 96, check=_non_negative, doc="RTP payload type of the H.264 stream"),
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
            "heartbeat_timeout": Param(
                "float", 3.0, check=_ardusub_heartbeat_timeout, doc="s, lost-link limit (>= 2 s)"
            ),
            "telemetry_timeout": Param("float", 1.0, check=_positive, doc="s, stale attitude/position limit"),
            "arm_mode": Param(SUB_MODES, "GUIDED", doc="ArduSub mode set (and confirmed) before arming"),
            "arm_timeout": Param("float", 5.0, check=_positive, doc="s to wait for each confirmation (mode, arming)"),
            "command": Param(
                ("setpoint", "manual_control"),
                "setpoint",
                doc="setpoint: SET_POSITION_TARGET_LOCAL_NED velocities (GUIDED, needs a position estimate); "
                "manual_control: open-loop MANUAL_CONTROL sticks (thrust), needs manual_full_stick",
            ),
            "manual_full_stick": Param(
                "record",
                None,
                item=_FULL_STICK,
                doc="measured speeds at full stick (manual_control only): stick = reference / these",
            ),
            "depth_sensor": Param(
                "int",
                0,
                check=_baro_instance,
                doc="baro instance of the depth sensor: 1-3 (SCALED_PRESSURE[n]); 0 = the highest reported",
            ),
            "max_speed": Param(
                "float", 1.0, check=_positive, doc="m/s clip on linear references (also bounds plausible DVL speeds)"
            ),
            "max_acceleration": Param(
                "float", 1.0, check=_positive, doc="m/s^2 the vehicle can reach (bounds plausible DVL changes)"
            ),
            "max_yaw_rate": Param("float", 0.5, check=_positive, doc="rad/s clip"),
            "actuated_dofs": Param("list", [True, True, True, False, False, True], check=_dofs),
            "dvl": Param("record", None, item=_SERIAL_OR_TCP, doc="Water Linked DVL for body velocity"),
            "ahrs": Param(
                "record",
                None,
                item={**_SERIAL_OR_TCP, "transport": Param(("serial",), "serial")},
                doc="MicroStrain AHRS",
            ),
            "ping": Param("record", None, item=_PING, doc="Blue Robotics Ping echosounder for altitude"),
        },
    ),
    "canopen_arm": (("arm",), {**_CANOPEN_COMMON, "joints": Param("list", required=True, item=_JOINT)}),
    "stereo_pipe_detector": (
        ("detector",),
        {
            "calibration": Param(
                "path",
                required=True,
                doc="OpenCV FileStorage stereo calibration, or a ROS camera_info file of the left camera",
            ),
            "calibration_right": Param(
                "path", None, doc="ROS camera_info of the right camera (or OpenCV's extrinsics file)"
            ),
            "left": Param("record", None, item=_CAMERA, doc="left camera (the URDF's stereo_camera frame)"),
            "right": Param("record", None, item=_CAMERA, doc="right camera"),
            "side_by_side": Param(
                "record",
                None,
                item=_CAMERA,
                doc="one source delivering left|right side by side, instead of left + right",
            ),
            "sync": Param(
                ("time", "sequence"), "time", doc="pair frames by grab time (live cameras) or frame number (recordings)"
            ),
            "pairing_tolerance_s": Param(
                "float", 0.02, check=_positive, doc="s, largest time between the two frames of a pair"
            ),
            "stale_timeout_s": Param("float", 0.5, check=_positive, doc="s without a frame before a camera is faulted"),
            **_DETECTOR_COMMON,
        },
    ),
    "mono_pipe_detector": (
        ("detector",),
        {
            "stream": Param(
                "record", {}, item=_RTP_STREAM, doc="the camera's H.264 RTP stream over UDP (BlueOS: port 5600)"
            ),
            "camera": Param(
                "record", required=True, item=_CAMERA_MODEL, doc="the camera's intrinsics (pinhole + distortion)"
            ),
            "stale_timeout_s": Param("float", 1.0, check=_positive, doc="s without a frame before the camera faults"),
            **_DETECTOR_COMMON,
        },
    ),
    "canopen_gripper": (
        ("gripper",),
        {
            **_CANOPEN_COMMON,
            "motors": Param("map", required=True, item=_DRIVE, doc="group name -> drive (distal, proximal, palm)"),
            "preshapes": Param(
                "map", {"cylindrical": 0.0}, check=_angle_map, doc="preshape name -> palm group position, rad"
            ),
            "close_velocity": Param("float", 0.5, check=_positive, doc="rad/s of finger groups while closing"),
            "open_position": Param("float", 0.0, doc="rad of finger groups when open"),
        },
    ),
}

DRIVER_SCHEMAS["reach_arm"] = (
    ("arm",),
    {
        **_REACH_LINK,
        **_REACH_FEEDBACK,
        "joints": Param("list", required=True, item=_REACH_JOINT, doc="in the URDF's order (base first)"),
        "mode_timeout": Param("float", 1.0, check=_positive, doc="s to see a mode change read back"),
        "urdf": Param("path", None, doc="model whose joint ranges and speeds must fit the device's own limits"),
        "limit_tolerance": Param("float", 0.01, check=_non_negative, doc="rad (rad/s) allowed past a device limit"),
    },
)
DRIVER_SCHEMAS["reach_jaw"] = (
    ("gripper",),
    {
        **{k: Param(v.kind, v.default, False, v.check, v.item, v.doc) for k, v in _REACH_LINK.items()},
        **_REACH_FEEDBACK,
        "transport": Param(("serial", "udp"), None, doc="give `link: arm` instead, or the jaw's own link"),
        "link": Param(("arm",), None, doc="`arm`: the jaw is on the reach_arm's link (its transport settings)"),
        "device_id": Param("int", 1, check=_reach_device_id, doc="the jaw's device id (0x01 on Alpha and Bravo)"),
        "close_by": Param(("velocity", "current"), "velocity", doc="close at close_speed, or by a current demand"),
        "close_speed": Param("float", 5.0, check=_positive, doc="mm/s while closing"),
        "open_speed": Param("float", 10.0, check=_positive, doc="mm/s while opening or preshaping"),
        "open_mm": Param("float", 12.0, check=_non_negative, doc="mm, opening of `open`"),
        "closed_mm": Param("float", 0.5, check=_non_negative, doc="mm, at or below this the jaw closed on nothing"),
        "preshapes": Param("map", {"parallel": 12.0}, check=_angle_map, doc="name -> opening in mm"),
    },
)


def _axes_map(v: Any) -> str | None:
    from hal.drivers.gamepad import gamepad_mapping  # the mapping's own check (axis and button names)

    try:
        gamepad_mapping({"axes": v})
    except (ValueError, KeyError, TypeError, AttributeError) as exc:
        return f"{str(exc).removeprefix('axes.')}; e.g. {{vx: {{axis: ABS_Y, scale: -1.0}}}}"
    return None


def _buttons_map(v: Any) -> str | None:
    from hal.drivers.gamepad import gamepad_mapping

    try:
        gamepad_mapping({"buttons": v})
    except (ValueError, TypeError, AttributeError) as exc:
        return f"{str(exc).removeprefix('buttons.')}; e.g. {{BTN_START: handback}}"
    return None


def _button_name(v: Any) -> str | None:
    from hal.drivers.gamepad import KEY_CODES

    return None if v in KEY_CODES else f"unknown button {v!r} (one of {', '.join(KEY_CODES)})"


#: The gamepad's mapping (``evdev_gamepad``; also accepted by ``sim``'s recorded pad).
_GAMEPAD_MAPPING = {
    "axes": Param(
        "map",
        None,
        check=_axes_map,
        doc="command component (vx vy vz wx wy wz) -> {axis: ABS_..., scale}; default: Xbox 360 pad on xpad",
    ),
    "buttons": Param("map", None, check=_buttons_map, doc="button (BTN_...) -> press name (handback, mode:..., stop)"),
    "deadman_button": Param("str", "BTN_TL", check=_button_name, doc="held to move (left bumper by default)"),
    "max_linear_mps": Param("float", 0.2, check=_positive, doc="m/s at full deflection"),
    "max_angular_rad_s": Param("float", 0.3, check=_positive, doc="rad/s at full deflection"),
}
DRIVER_SCHEMAS["evdev_gamepad"] = (
    ("gamepad",),
    {
        "device": Param("str", required=True, doc="/dev/input/... path (a /dev/input/by-id/ path survives a replug)"),
        **_GAMEPAD_MAPPING,
        "grab": Param("bool", False, doc="take the device for this process alone (EVIOCGRAB)"),
        "reopen_s": Param("float", 1.0, check=_positive, doc="s between attempts to open an absent device"),
        "timeout_s": Param("float", 0.5, check=_positive, doc="s, the reader thread's watchdog"),
    },
)
DRIVER_SCHEMAS["foxglove"] = (("foxglove",), {})
DRIVER_SCHEMAS["terminal"] = (("keyboard",), {})

BUS_SCHEMA = {
    "interface": Param("str", required=True, doc="python-can interface: socketcan, pcan, udp_multicast, ..."),
    "channel": Param("str", required=True),
    "bitrate": Param("int", None, check=_positive),
    "port": Param("int", None, check=_port, doc="udp_multicast only"),
    "hop_limit": Param("int", None, check=_non_negative, doc="udp_multicast only; 0 keeps frames on this host"),
    "host_node_id": Param("int", 127, check=_node_id, doc="node ID of this computer's heartbeat on the bus"),
    "sync_period": Param(
        "float", None, check=_positive, doc="s, this computer sends SYNC at this period (for `transmission: sync`)"
    ),
}

#: Keys an older config may still hold, refused with an explanation.
RETIRED_KEYS = {
    (
        "canopen_gripper",
        "current_scale",
    ): "`current_scale` was never used: motor currents are 0x6078 per mille of the rated "
    "current (0x6075, or `rated_current_a` when the EDS lacks it); remove it",
}
