"""HAL config loading: shipped examples load; mistakes give file:line:column + field."""

from __future__ import annotations

from pathlib import Path

import pytest

from hal.config import load_hal_config
from maris_common.yamlsrc import ConfigError

CONFIGS = Path(__file__).resolve().parents[2] / "hal" / "configs"


def write(tmp_path: Path, text: str) -> Path:
    p = tmp_path / "hal.yaml"
    p.write_text(text)
    return p


def errors(tmp_path: Path, text: str) -> str:
    with pytest.raises(ConfigError) as exc:
        load_hal_config(write(tmp_path, text))
    return str(exc.value)


def test_shipped_sim_config_has_every_role() -> None:
    cfg = load_hal_config(CONFIGS / "sim.yaml")
    assert cfg.is_sim  # the operator inputs' real drivers (foxglove, terminal) do not make it a mixed setup
    assert cfg.roles == {"vehicle", "arm", "gripper", "detector", "wrench_sensor", "gamepad", "foxglove", "keyboard"}
    assert cfg.operator_roles == {"gamepad", "foxglove", "keyboard"}


def test_operator_inputs_in_a_hal_config(tmp_path: Path) -> None:
    """A field gamepad with its mapping (defaults filled in); a mapping naming an unknown
    button says where; a recorded pad (simulated time) with a real vehicle is refused."""
    field = tmp_path / "field.yaml"
    field.write_text(
        "devices:\n  vehicle: {driver: ardusub, url: 'udpin:127.0.0.1:14550'}\n  arm: {driver: sim}\n"
        "  gamepad: {driver: evdev_gamepad, device: /dev/input/event3, buttons: {BTN_START: handback},"
        " max_linear_mps: 0.3}\n  foxglove: {driver: foxglove}\n"
    )
    c = load_hal_config(field)
    assert c.devices["gamepad"].params["max_linear_mps"] == 0.3
    assert c.devices["gamepad"].params["deadman_button"] == "BTN_TL"
    assert c.operator_roles == {"gamepad", "foxglove"} and not c.is_sim
    sim = tmp_path / "sim_pad.yaml"
    sim.write_text(
        "devices:\n  vehicle: {driver: sim}\n  arm: {driver: sim}\n"
        "  gamepad: {driver: evdev_gamepad, device: /dev/input/event3, buttons: {BTN_NOPE: handback}}\n"
    )
    with pytest.raises(ConfigError) as err:
        load_hal_config(sim)
    assert f"{sim}:4:" in str(err.value) and "BTN_NOPE: unknown button" in str(err.value)
    mixed = tmp_path / "mixed.yaml"
    mixed.write_text(
        "devices:\n  vehicle: {driver: ardusub, url: 'udpin:127.0.0.1:14550'}\n  arm: {driver: sim}\n"
        "  gamepad: {driver: sim}\n"
    )
    with pytest.raises(ConfigError) as err:
        load_hal_config(mixed)
    assert f"{mixed}:4:" in str(err.value) and "needs every device on the simulator" in str(err.value)


def test_shipped_field_config_resolves_eds_and_defaults() -> None:
    cfg = load_hal_config(CONFIGS / "bluerov2_canopen_arm.yaml")
    assert cfg.roles == {"vehicle", "arm", "gripper", "detector"}  # the stereo pipe detector (docs/vision.md)
    arm = cfg.devices["arm"].params
    assert Path(arm["eds"]).is_file() and Path(arm["eds"]).is_absolute()
    assert [j["node_id"] for j in arm["joints"]] == [1, 2, 3, 4, 5, 6, 7]
    assert arm["stale_timeout"] == 0.2  # default filled in
    assert cfg.devices["vehicle"].params["dvl"]["port"] == 16171
    assert cfg.buses["can0"].options == {"bitrate": 1000000}


def test_typo_in_driver_is_located_and_suggested(tmp_path: Path) -> None:
    msg = errors(tmp_path, "devices:\n  vehicle: {driver: sim}\n  arm:\n    driver: canopen_armm\n")
    assert "hal.yaml:4:13: devices.arm.driver: unknown driver `canopen_armm` (did you mean `canopen_arm`?)" in msg


def test_all_problems_reported_at_once(tmp_path: Path) -> None:
    text = """\
buses:
  can0: {interface: socketcan, channel: can0}
devices:
  vehicle:
    driver: ardusub
    url: "udpin:0.0.0.0:14550"
    heartbeat_timout: 2
  arm:
    driver: canopen_arm
    bus: can1
    eds: missing.eds
    joints:
      - {name: j1, node_id: 200}
      - {name: j2, node_id: 5, max_velocity: fast}
  gripper: {driver: sim}
"""
    msg = errors(tmp_path, text)
    lines = msg.splitlines()
    assert any(
        ":7:23: devices.vehicle.heartbeat_timout: unknown key" in ln and "heartbeat_timeout" in ln for ln in lines
    )
    assert any(":10:10: devices.arm.bus: unknown bus `can1` (did you mean `can0`?)" in ln for ln in lines)
    assert any(":11:10: devices.arm.eds: file not found" in ln for ln in lines)
    assert any(":13:29: devices.arm.joints[0].node_id: CANopen node ID must be in 1..127" in ln for ln in lines)
    assert any("devices.arm.joints[1].max_velocity: expected float" in ln for ln in lines)
    assert not any("cannot be mixed" in ln for ln in lines)  # sim roles next to real ones are allowed (mixed setups)


def test_missing_roles_and_fields(tmp_path: Path) -> None:
    msg = errors(tmp_path, "devices:\n  vehicle: {driver: ardusub}\n  detector: {driver: sim}\n")
    assert "devices.vehicle: missing required field `url`" in msg
    assert "missing required role `arm`" in msg


def test_bad_role_and_duplicate_nodes(tmp_path: Path) -> None:
    eds = CONFIGS.parent / "data" / "cia402_minimal.eds"
    text = f"""\
buses: {{can0: {{interface: udp_multicast, channel: 239.74.163.2}}}}
devices:
  vehicle: {{driver: ardusub, url: "udpin:127.0.0.1:1"}}
  arm: {{driver: canopen_arm, bus: can0, eds: {eds}, joints: [{{name: a, node_id: 3}}, {{name: b, node_id: 3}}]}}
  grippr: {{driver: sim}}
"""
    msg = errors(tmp_path, text)
    assert "unknown role `grippr` (did you mean `gripper`?)" in msg
    assert "node ID 3 used twice" in msg


def test_udp_multicast_bus_stays_on_host(tmp_path: Path) -> None:
    eds = CONFIGS.parent / "data" / "cia402_minimal.eds"
    text = f"""\
buses: {{can0: {{interface: udp_multicast, channel: 239.74.163.2, port: 45000}}}}
devices:
  vehicle: {{driver: ardusub, url: "udpin:127.0.0.1:14550"}}
  arm: {{driver: canopen_arm, bus: can0, eds: {eds}, joints: [{{name: a, node_id: 3}}]}}
"""
    cfg = load_hal_config(write(tmp_path, text))
    assert cfg.buses["can0"].options == {"port": 45000, "hop_limit": 0}


def test_yaml_syntax_error_and_wrong_kinds(tmp_path: Path) -> None:
    assert "hal.yaml:3:1: <root>: YAML syntax error" in errors(tmp_path, "devices:\n  vehicle: [\n")
    msg = errors(
        tmp_path,
        "devices:\n  vehicle: {driver: ardusub, url: 'ftp://x', actuated_dofs: [true]}\n  arm: {driver: sim}\n",
    )
    assert "devices.vehicle.url: MAVLink URL must look like" in msg
    assert "devices.vehicle.actuated_dofs: must be a list of 6 booleans" in msg
    msg = errors(
        tmp_path,
        "devices:\n  vehicle: {driver: ardusub, url: 'udp:1.2.3.4:5', arm_mode: MANUL}\n  arm: {driver: sim}\n",
    )
    assert "devices.vehicle.arm_mode: must be one of" in msg and "(did you mean `MANUAL`?)" in msg
    msg = errors(
        tmp_path,
        "devices:\n  vehicle: {driver: ardusub, url: 'udp:1.2.3.4:5', arm_mode: MANUAL}\n  arm: {driver: sim}\n",
    )
    assert "devices.vehicle.arm_mode: velocity setpoints are only followed in GUIDED" in msg
    eds = CONFIGS.parent / "data" / "cia402_minimal.eds"
    text = f"""\
buses: {{can0: {{interface: socketcan, channel: can0}}}}
devices:
  vehicle: {{driver: ardusub, url: "udpin:127.0.0.1:1", dvl: {{transport: serial, prot: 3}}}}
  arm: {{driver: canopen_arm, bus: can0, eds: {eds}, joints: [{{name: a, node_id: 1}}]}}
  gripper: {{driver: canopen_gripper, bus: can0, eds: {eds}, motors: {{palm: {{node_id: 2}}}}, preshapes: {{wide: big}}}}
"""
    msg = errors(tmp_path, text)
    assert "devices.vehicle.dvl.prot: unknown key `prot` (did you mean `port`?)" in msg
    assert "devices.vehicle.dvl: serial transport needs `device`" in msg
    assert "devices.gripper.preshapes: must map preshape names to palm angles" in msg


# ----------------------------------------------------------------------------- fuzz

from hypothesis import given, settings  # noqa: E402
from hypothesis import strategies as st  # noqa: E402

from hal.config import DRIVER_SCHEMAS, HalConfig  # noqa: E402

_KEYS = sorted(
    {k for _, schema in DRIVER_SCHEMAS.values() for k in schema} | {"driver", "name", "node_id", "transport", "device"}
)
_scalars = st.one_of(
    st.none(),
    st.booleans(),
    st.integers(-5, 200),
    st.floats(allow_nan=True),
    st.text(max_size=8),
    st.sampled_from(list(DRIVER_SCHEMAS) + ["can0", "tcp", "serial"]),
)
_values = st.recursive(
    _scalars,
    lambda inner: st.one_of(st.lists(inner, max_size=3), st.dictionaries(st.sampled_from(_KEYS), inner, max_size=4)),
    max_leaves=12,
)


@pytest.mark.slow
@settings(max_examples=80, deadline=None)
@given(
    devices=st.dictionaries(st.sampled_from(["vehicle", "arm", "gripper", "detector", "grippr"]), _values, max_size=4),
    buses=st.one_of(st.none(), st.dictionaries(st.sampled_from(["can0", "x"]), _values, max_size=2)),
)
def test_any_config_gives_a_hal_config_or_a_located_error(tmp_path_factory, devices: dict, buses: dict | None) -> None:  # noqa: ANN001
    import yaml

    from maris_common.yamlsrc import ConfigError

    path = tmp_path_factory.mktemp("fuzz") / "hal.yaml"
    path.write_text(yaml.safe_dump({"devices": devices, "buses": buses}))
    try:
        cfg = load_hal_config(path)
    except ConfigError as exc:
        assert exc.issues and all(str(i).startswith(f"{path}:") for i in exc.issues)
        return
    assert isinstance(cfg, HalConfig) and {"vehicle", "arm"} <= cfg.roles


FIELD = """\
buses:
  can0: {interface: socketcan, channel: can0, sync_period: 0.01}
devices:
  vehicle: {driver: ardusub, url: "udpin:0.0.0.0:14550"}
  arm:
    driver: canopen_arm
    bus: can0
    eds: EDS
    transmission: sync
    stale_timeout: 0.05
    joints:
      - {name: j1, node_id: 1}
      - {name: j2, node_id: 10}
  gripper:
    driver: canopen_gripper
    bus: can0
    eds: EDS
    motors: {distal: {node_id: 10}, palm: {node_id: 12}}
"""


def test_sync_period_belongs_to_the_bus_not_to_python_can(tmp_path: Path) -> None:
    eds = str(CONFIGS.parent / "data" / "cia402_minimal.eds")
    text = FIELD.replace("EDS", eds).replace("node_id: 10}\n  gripper", "node_id: 2}\n  gripper")
    cfg = load_hal_config(write(tmp_path, text))
    assert cfg.buses["can0"].sync_period == 0.01 and "sync_period" not in cfg.buses["can0"].options
    assert cfg.devices["arm"].params["transmission"] == "sync"


def test_canopen_mistakes_are_config_errors_with_their_place(tmp_path: Path) -> None:
    eds = str(CONFIGS.parent / "data" / "cia402_minimal.eds")
    text = FIELD.replace("EDS", eds)
    msg = errors(tmp_path, text)
    assert (
        "hal.yaml:18:32: devices.gripper.motors.distal.node_id: node ID 10 is already used by the arm on bus `can0`"
        in msg
    )
    text = FIELD.replace("EDS", eds).replace("node_id: 10}\n  gripper", "node_id: 2}\n  gripper")
    text = text.replace(", sync_period: 0.01", "").replace(
        "    stale_timeout: 0.05\n", "    stale_timeout: 0.05\n    current_scale: 2.0\n"
    )
    text = text.replace("motors: {distal", "current_scale: 1.5\n    motors: {distal")
    text += "    host_heartbeat_timeout: 0.02\n"
    text = text.replace('url: "udpin:0.0.0.0:14550"', 'url: "udpin:0.0.0.0:99999"')
    msg = errors(tmp_path, text)
    assert "hal.yaml:4:35: devices.vehicle.url: MAVLink URL port must be a number in 1..65535, got `99999`" in msg
    assert "devices.arm.transmission: `sync` needs a SYNC producer: set `sync_period` on bus `can0`" in msg
    assert "devices.gripper.current_scale: `current_scale` was never used" in msg and "rated_current_a" in msg
    assert "devices.arm.current_scale: unknown key" in msg  # only the gripper ever had it
    assert (
        "devices.gripper.host_heartbeat_timeout: must be 0 (drives do not watch this computer) or in 0.1..65.535 s"
        in msg
    )
    text = FIELD.replace("EDS", eds).replace("node_id: 10}\n  gripper", "node_id: 2}\n  gripper")
    assert "devices.arm.stale_timeout: must be at least twice the bus sync_period (0.01 s)" in errors(
        tmp_path, text.replace("stale_timeout: 0.05", "stale_timeout: 0.015")
    )


def test_validate_with_hal_checks_the_arm_joints_against_the_model(tmp_path: Path) -> None:
    from mission.loader import load_mission

    missions = CONFIGS.parents[1] / "missions"
    text = (
        (CONFIGS / "bluerov2_canopen_arm.yaml").read_text().replace(": ../data/", f": {CONFIGS.parent}/data/")
    )  # eds, calibration
    bad = text.replace("- {name: j4_elbow_pitch,    node_id: 4", "- {name: elbow,    node_id: 4")
    with pytest.raises(ConfigError) as exc:
        load_mission(missions / "survey_only.yaml", hal_config=write(tmp_path, bad))
    assert (
        "devices.arm.joints: joint names differ (they must match in order): #4 is `elbow` in the HAL, "
        "`j4_elbow_pitch` in the default model r2_uma.urdf" in str(exc.value)
    )
    short = "\n".join(ln for ln in text.splitlines() if "j5_" not in ln and "j6_" not in ln)
    with pytest.raises(ConfigError) as exc:
        load_mission(missions / "survey_only.yaml", hal_config=write(tmp_path, short))
    assert "the HAL arm has 5 joint(s)" in str(exc.value) and "the default model r2_uma.urdf has 7" in str(exc.value)
