"""The keyboard as an operator input: the key reader on a real pseudo-terminal pushes
jog keys (velocities) and teleop buttons into the ``keyboard`` input, supervisor keys into
the command queue; through the real CLI, a held key jogs the vehicle of a teleop mission
and ``h`` hands control back."""

from __future__ import annotations

import os
import pty
import select
import subprocess
import sys
import time

import pytest

from hal.drivers.pushed_input import PushedInput
from mission.logs.reader import read_log
from mission.runtime.operator import KEY_SPEED, CommandQueue, KeyReader

from .conftest import ROOT

pytestmark = pytest.mark.realtime  # keys held on a terminal, at its repeat rate

ENV = dict(os.environ, PYTHONPATH=str(ROOT))


def test_jog_keys_push_velocities_and_buttons_presses_on_a_real_terminal():
    master, slave = pty.openpty()
    stream = os.fdopen(slave, "r")
    queue = CommandQueue()
    device = PushedInput("keyboard", lambda: 3.0)
    reader = KeyReader(queue, stream)
    try:
        reader.attach_input(device)
        os.write(master, b"iiJ")  # forward twice, then left (upper case works too)
        time.sleep(0.05)
        reader.poll()
        s = device.latest()
        assert s.velocity.values.tolist() == [0.0, -KEY_SPEED[0], 0.0, 0.0, 0.0, 0.0] and s.velocity.t == 3.0
        os.write(master, b"mhtp")
        time.sleep(0.05)
        reader.poll()
        s = device.latest()
        assert s.velocity.values[5] == KEY_SPEED[1]
        assert s.presses == {"handback": 1, "mode:tool_velocity": 1}
        assert [c.command for c in queue.drain()] == ["pause"]  # the supervisor's keys are unchanged
    finally:
        reader.close()
        stream.close()
        os.close(master)


MISSION = """name: keys
safety:
  max_depth_m: 4.0
  min_altitude_m: 0.5
  max_duration_s: 120
  geofence: {north_m: [0, 25], east_m: [0, 12], down_m: [0, 4]}
tree:
  teleop: {modes: [vehicle_velocity], inputs: [keyboard], timeout_s: 60}
abort:
  action: {run: hold, timeout_s: 10}
"""


@pytest.mark.slow
def test_a_held_key_jogs_the_vehicle_and_h_hands_back_through_the_cli(tmp_path):
    mission = tmp_path / "keys.yaml"
    mission.write_text(MISSION)
    log = tmp_path / "keys.mcap"
    master, slave = pty.openpty()
    argv = [sys.executable, "-m", "mission.cli", "sim", str(mission), "--realtime", "--log", str(log), "--seed", "1"]
    proc = subprocess.Popen(argv, stdin=slave, stdout=slave, stderr=slave, env=ENV, cwd=ROOT, start_new_session=True)
    os.close(slave)
    text = ""

    def read_for(seconds: float) -> None:
        nonlocal text
        end = time.monotonic() + seconds
        while time.monotonic() < end:
            if select.select([master], [], [], 0.05)[0]:
                try:
                    text += os.read(master, 4096).decode(errors="replace")
                except OSError:
                    return

    try:
        deadline = time.monotonic() + 60
        while "teleop keys" not in text:
            assert time.monotonic() < deadline, text[-2000:]
            read_for(0.2)
        for _ in range(60):  # 'i' held for 3 s: the terminal's auto-repeat, at 20 Hz
            os.write(master, b"i")
            read_for(0.05)
        read_for(1.5)
        os.write(master, b"h")
        deadline = time.monotonic() + 60
        while proc.poll() is None:
            assert time.monotonic() < deadline, text[-2000:]
            read_for(0.2)
    finally:
        if proc.poll() is None:
            proc.kill()
        os.close(master)
    assert proc.returncode == 0, text[-2000:]
    events = read_log(log).messages("/events")
    control = [e for e in events if e["kind"] == "control"]
    assert [e["fields"]["who"] for e in control] == ["operator", "autonomy"]
    assert "keyboard's handback button" in control[1]["message"]
    inputs = [e["fields"]["role"] for e in events if e["kind"] == "teleop_input"]
    assert inputs[:2] == ["keyboard", None]
    nav = read_log(log).messages("/vehicle/navigation")
    assert nav[-1]["position"][0] - nav[0]["position"][0] > 0.2
