"""Set-up errors that cannot recover fail the start at ``open()``, naming the HAL
config field at file:line, for every device kind: a serial device that does not
exist, a host name that does not resolve, an address this computer does not have,
an EDS that is not an EDS, a video device that is not there.

Each start runs in a network namespace of its own (``unshare -n``, loopback only),
so the host names below are looked up without any traffic leaving the machine
(the resolver is unreachable there: the name does not resolve)."""

from __future__ import annotations

import json
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from hal.testing.peers import free_udp_port

ROOT = Path(__file__).resolve().parents[2]
PROBE = Path(__file__).with_name("setup_probe.py")
DATA = ROOT / "hal" / "data"


def netns_available() -> bool:
    if shutil.which("unshare") is None or shutil.which("ip") is None:
        return False
    return subprocess.run(["unshare", "-n", "true"], capture_output=True).returncode == 0


pytestmark = pytest.mark.skipif(not netns_available(), reason="needs `unshare -n` (root) for an isolated network")


def start(tmp_path: Path, text: str) -> dict:
    cfg = tmp_path / "hal.yaml"
    cfg.write_text(text)
    cmd = f"ip link set lo up && exec {sys.executable} {PROBE} {cfg}"
    out = subprocess.run(["unshare", "-n", "sh", "-c", cmd], capture_output=True, text=True, timeout=120, cwd=ROOT)
    assert out.returncode == 0, out.stderr
    result = json.loads(out.stdout.strip().splitlines()[-1])
    result["config"] = str(cfg)
    return result


def line_of(text: str, needle: str) -> int:
    return next(i for i, ln in enumerate(text.splitlines(), 1) if needle in ln)


VEHICLE_OK = '  vehicle: {{driver: ardusub, url: "udpin:127.0.0.1:{port}"}}\n'
ARM_OK = "  arm: {driver: reach_arm, transport: udp, host: 127.0.0.1, joints: [{name: j, device_id: 2}]}\n"

CASES = {
    "mavlink serial": (
        'devices:\n  vehicle: {driver: ardusub, url: "/dev/ttyUSB9"}\n' + ARM_OK,
        "url:",
        "devices.vehicle.url: ArduSub MAVLink link: serial device /dev/ttyUSB9 does not exist",
    ),
    "mavlink host": (
        'devices:\n  vehicle: {driver: ardusub, url: "tcp:rov-topside.invalid:5760"}\n' + ARM_OK,
        "url:",
        "devices.vehicle.url: ArduSub MAVLink link: host name `rov-topside.invalid` does not resolve",
    ),
    "mavlink listen address": (
        'devices:\n  vehicle: {driver: ardusub, url: "udpin:10.99.99.99:14550"}\n' + ARM_OK,
        "url:",
        "cannot listen on 10.99.99.99:14550: the address is not an address of this computer",
    ),
    "dvl host": (
        'devices:\n  vehicle:\n    driver: ardusub\n    url: "udpin:127.0.0.1:{port}"\n'
        "    dvl: {transport: tcp, host: dvl-a50.invalid}\n" + ARM_OK,
        "dvl:",
        "devices.vehicle.dvl: DVL: host name `dvl-a50.invalid` does not resolve",
    ),
    "ahrs serial": (
        'devices:\n  vehicle:\n    driver: ardusub\n    url: "udpin:127.0.0.1:{port}"\n'
        "    ahrs: {transport: serial, device: /dev/ttyUSB8}\n" + ARM_OK,
        "ahrs:",
        "devices.vehicle.ahrs: AHRS: serial device /dev/ttyUSB8 does not exist",
    ),
    "ping serial": (
        'devices:\n  vehicle:\n    driver: ardusub\n    url: "udpin:127.0.0.1:{port}"\n'
        "    ping: {transport: serial, device: /dev/ttyUSB7}\n" + ARM_OK,
        "ping:",
        "devices.vehicle.ping: Ping echosounder: serial device /dev/ttyUSB7 does not exist",
    ),
    "ping host": (
        'devices:\n  vehicle:\n    driver: ardusub\n    url: "udpin:127.0.0.1:{port}"\n'
        "    ping: {transport: udp, host: blueos.invalid}\n" + ARM_OK,
        "ping:",
        "devices.vehicle.ping: Ping echosounder: host name `blueos.invalid` does not resolve",
    ),
    "reach serial": (
        "devices:\n" + VEHICLE_OK + "  arm:\n    driver: reach_arm\n    transport: serial\n"
        "    device: /dev/ttyUSB9\n    joints: [{{name: j, device_id: 2}}]\n",
        "transport:",
        "devices.arm.transport: Reach arm link: serial device /dev/ttyUSB9 does not exist",
    ),
    "reach host": (
        "devices:\n" + VEHICLE_OK + "  arm:\n    driver: reach_arm\n    transport: udp\n"
        "    host: bravo7.invalid\n    joints: [{{name: j, device_id: 2}}]\n",
        "transport:",
        "devices.arm.transport: Reach arm link: host name `bravo7.invalid` does not resolve",
    ),
    "canopen eds": (
        "buses:\n  can0: {{interface: virtual, channel: t}}\ndevices:\n" + VEHICLE_OK + "  arm:\n"
        "    driver: canopen_arm\n    bus: can0\n    eds: " + str(DATA / "test_eds" / "garbage.eds") + "\n"
        "    joints: [{{name: j, node_id: 1}}]\n",
        "eds:",
        "devices.arm.eds: ",
    ),
    "camera device": (
        "devices:\n" + VEHICLE_OK + ARM_OK.replace("{", "{{").replace("}", "}}") + "  detector:\n"
        "    driver: stereo_pipe_detector\n    calibration: " + str(DATA / "mako_g125_stereo_example.yaml") + "\n"
        "    left: {{source: /dev/video9}}\n    right: {{source: /dev/video8}}\n",
        "left:",
        "devices.detector.left.source: left camera: video device /dev/video9 does not exist",
    ),
}


@pytest.mark.parametrize("case", sorted(CASES))
def test_setup_error_fails_the_start_at_open_naming_the_field(tmp_path: Path, case: str) -> None:
    template, field_line, message = CASES[case]
    text = template.replace("{port}", str(free_udp_port())) if "{port}" in template else template
    text = text.replace("{{", "{").replace("}}", "}")
    result = start(tmp_path, text)
    assert result["type"] in ("SetupError", "EdsSetupError"), result
    where = f"{result['config']}:{line_of(text, field_line)}:"
    assert result["error"].startswith(where) and message in result["error"], result
    if case == "canopen eds":
        assert "garbage.eds" in result["error"] and result["stage"] == "build"
    elif case == "camera device":
        assert result["stage"] == "build"  # found before the detector loads its model and the vision code
    else:
        assert result["stage"] == "open"
    print(f"{case}: start refused after {result['elapsed_s']:.2f} s")
