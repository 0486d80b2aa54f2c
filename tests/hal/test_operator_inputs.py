"""Operator inputs of the HAL: the gamepad's decoding on recorded kernel event
streams, the evdev driver (unplug, replug, a mapping that does not fit), the
pushed input of the live view and the keyboard, the simulator's recorded pad.

This machine's kernel has no ``uinput`` (``/dev/uinput`` is absent and a node
made for it answers ENODEV), so the driver is tested here with recorded event
streams replayed into its decoding and, for its device handling, with a
stand-in for the opened device that serves such a stream and fails as a pad
pulled out does (``ENODEV``). ``test_a_real_virtual_pad_through_uinput`` runs
the driver against a real virtual device where ``uinput`` exists, and is
skipped here with that reason."""

from __future__ import annotations

import errno
import os
import time
from pathlib import Path

import numpy as np
import pytest

from hal.drivers.evemu import AbsRange, RawEvent, evemu_text, parse_evemu, read_evemu
from hal.drivers.gamepad import (
    ABS_CODES,
    EV_ABS,
    EV_KEY,
    EV_SYN,
    KEY_CODES,
    SYN_DROPPED,
    SYN_REPORT,
    XBOX360_RANGES,
    EvdevGamepad,
    GamepadDecoder,
    gamepad_mapping,
    normalized,
)
from hal.drivers.pushed_input import PushedInput
from hal.interfaces import HealthState
from hal.testing.gamepad_session import Hold, session, write_session
from maris_common.yamlsrc import ConfigError

ABS_Y, ABS_X, ABS_RX = ABS_CODES["ABS_Y"], ABS_CODES["ABS_X"], ABS_CODES["ABS_RX"]
BTN_TL, BTN_START = KEY_CODES["BTN_TL"], KEY_CODES["BTN_START"]


def _play(decoder: GamepadDecoder, events: list[RawEvent], until: float) -> None:
    for ev in events:
        if ev.t <= until:
            decoder.feed(ev)


# --------------------------------------------------------------------------- recordings


def test_an_evemu_recording_reads_back_what_was_written():
    rec = session([Hold(0.1, {"ABS_Y": -1.0}, ["BTN_TL"]), Hold(0.5)], end_s=0.8)
    back = parse_evemu(evemu_text(rec))
    assert back.name == rec.name and back.axes == rec.axes and back.events == rec.events
    assert all(e.t >= 0 for e in back.events) and back.events[-1].type == EV_SYN


def test_a_bad_evemu_line_names_its_file_and_line(tmp_path: Path):
    f = tmp_path / "pad.evemu"
    f.write_text(
        "N: pad\nA: 01 -32768 32767 16 128 0\nE: 0.1 0003 0001\nE: 0.2 0003 0001 5\nE: 0.05 0000 0000 0000\nQ: what\n"
    )
    with pytest.raises(ConfigError) as err:
        read_evemu(f)
    text = str(err.value)
    assert f"{f}:3:" in text and "missing fields" in text
    assert f"{f}:5:" in text and "before the previous event" in text
    assert f"{f}:6:" in text and "unknown line kind" in text


# --------------------------------------------------------------------------- decoding


def test_the_xpad_sticks_have_a_dead_zone_and_full_deflection_is_one():
    r = XBOX360_RANGES[ABS_Y]
    assert normalized(0, r) == 0.0 and normalized(127, r) == 0.0 and normalized(-128, r) == 0.0  # within flat
    assert normalized(200, r) > 0.0
    assert normalized(32767, r) == pytest.approx(1.0, abs=1e-4) and normalized(-32768, r) == -1.0
    trigger = XBOX360_RANGES[ABS_CODES["ABS_Z"]]
    assert normalized(0, trigger) == 0.0 and normalized(255, trigger) == 1.0


def test_a_recorded_jog_decodes_to_the_command_the_sticks_give():
    """Left stick pushed up (negative y) with the dead-man held: forward at the
    full-stick speed; the right stick right turns (positive yaw rate); released: zero."""
    m = gamepad_mapping()
    rec = session(
        [Hold(0.1, {"ABS_Y": -1.0, "ABS_RX": 0.5}, ["BTN_TL"]), Hold(1.0, {}, ["BTN_TL"]), Hold(1.5)], end_s=2.0
    )
    d = GamepadDecoder(m, rec.axes)
    _play(d, rec.events, 0.05)
    assert not d.deadman and np.all(d.command() == 0)
    d2 = GamepadDecoder(m, rec.axes)
    _play(d2, rec.events, 0.5)
    v = d2.command()
    assert d2.deadman
    assert v[0] == pytest.approx(m.max_linear_mps, rel=1e-3)
    assert v[5] == pytest.approx(0.5 * m.max_angular_rad_s, rel=1e-2)
    assert np.all(v[1:5] == 0.0)
    d3 = GamepadDecoder(m, rec.axes)
    _play(d3, rec.events, 1.3)
    assert d3.deadman and np.allclose(d3.command(), 0.0)
    d4 = GamepadDecoder(m, rec.axes)
    _play(d4, rec.events, 2.0)
    assert not d4.deadman


def test_a_packet_counts_only_when_its_syn_report_arrives():
    d = GamepadDecoder(gamepad_mapping(), XBOX360_RANGES)
    d.feed(RawEvent(0.0, EV_ABS, ABS_Y, -32768))
    assert np.all(d.command() == 0)  # not committed yet
    assert d.feed(RawEvent(0.0, EV_SYN, SYN_REPORT, 0))
    assert d.command()[0] > 0


def test_presses_count_each_press_once_not_the_auto_repeat():
    d = GamepadDecoder(gamepad_mapping(), XBOX360_RANGES)
    for t, value in ((0.0, 1), (0.3, 2), (0.35, 2), (0.4, 0), (0.6, 1), (0.7, 0)):
        d.feed(RawEvent(t, EV_KEY, BTN_START, value))
        d.feed(RawEvent(t, EV_SYN, SYN_REPORT, 0))
    assert d.presses == {"handback": 2}
    assert d.sample(1.0).count("handback") == 2


def test_syn_dropped_discards_the_cut_packet_and_asks_for_the_device_state():
    """After SYN_DROPPED the kernel's documentation says: ignore every event up to and
    including the next SYN_REPORT, then read the state from the device."""
    d = GamepadDecoder(gamepad_mapping(), XBOX360_RANGES)
    d.feed(RawEvent(0.0, EV_SYN, SYN_DROPPED, 0))
    d.feed(RawEvent(0.0, EV_ABS, ABS_Y, -32768))
    d.feed(RawEvent(0.0, EV_KEY, BTN_START, 1))
    assert not d.feed(RawEvent(0.0, EV_SYN, SYN_REPORT, 0))
    assert np.all(d.command() == 0) and d.presses == {} and d.needs_resync and d.drops == 1
    d.set_state({ABS_Y: -32768}, {BTN_TL})  # what EVIOCGABS / EVIOCGKEY say
    assert not d.needs_resync and d.deadman and d.command()[0] > 0
    assert d.presses == {}  # a button found held counts no press: its press was not seen


def test_a_mapping_naming_an_axis_the_device_lacks_is_refused():
    with pytest.raises(ValueError, match="no axis ABS_X, ABS_RX"):
        GamepadDecoder(gamepad_mapping(), {ABS_Y: AbsRange(-32768, 32767, 16, 128)})
    with pytest.raises(ValueError, match=r"axes.vq: unknown component"):
        gamepad_mapping({"axes": {"vq": {"axis": "ABS_Y"}}})
    with pytest.raises(ValueError, match="unknown button"):
        gamepad_mapping({"buttons": {"BTN_NOPE": "handback"}})


# --------------------------------------------------------------------------- the evdev driver


class RecordedPad:
    """Stands in for an opened ``/dev/input/eventN`` (no ``uinput`` here, see the module
    docstring): its ranges, its state, and the recorded events, served as a reader
    would get them (those whose time has come, by the wall clock since it was opened),
    through a pipe the driver's ``select`` waits on. ``unplug()`` makes every read fail
    with ENODEV, as the kernel does for a device that is gone."""

    def __init__(self, events: list[RawEvent], keys: set[int] | None = None) -> None:
        self.name = "Microsoft X-Box 360 pad"
        self.events = list(events)
        self.t0 = time.monotonic()
        self.gone = False
        self.closed = False
        self._r, self._w = os.pipe()
        os.write(self._w, b"x")  # always readable: the driver reads what is due
        self._keys = keys if keys is not None else set(KEY_CODES.values())

    def fileno(self) -> int:
        return self._r

    def ranges(self) -> dict[int, AbsRange]:
        return dict(XBOX360_RANGES)

    def key_codes(self) -> set[int]:
        return set(self._keys)

    def state(self) -> tuple[dict[int, int], set[int]]:
        if self.gone:
            raise OSError(errno.ENODEV, "No such device")
        return {}, set()

    def read_events(self) -> list[RawEvent]:
        if self.gone:
            raise OSError(errno.ENODEV, "No such device")
        now = time.monotonic() - self.t0
        due = [e for e in self.events if e.t <= now]
        self.events = self.events[len(due) :]
        time.sleep(0.005)
        return due

    def close(self) -> None:
        self.closed = True
        os.close(self._r)
        os.close(self._w)


def _wait(cond, timeout: float = 3.0) -> bool:
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        if cond():
            return True
        time.sleep(0.01)
    return False


def test_the_driver_reads_a_pad_and_an_unplug_leaves_a_stale_sample_and_missing_health():
    rec = session([Hold(0.0, {"ABS_Y": -1.0}, ["BTN_TL"])], end_s=0.3)
    pads: list[RecordedPad] = []
    refused = [0]
    plugged = [True]

    def open_device(path: str) -> RecordedPad:
        if not plugged[0]:  # the node is gone until the pad is plugged in again
            refused[0] += 1
            raise FileNotFoundError(errno.ENOENT, "No such file or directory", path)
        pads.append(RecordedPad(rec.events if not pads else []))
        return pads[-1]

    clock = time.monotonic
    pad = EvdevGamepad(
        {"device": "/dev/input/by-id/usb-pad-event-joystick", "reopen_s": 0.05}, clock, open_device=open_device
    )
    pad.connect()
    try:
        assert _wait(lambda: (s := pad.latest()) is not None and s.deadman and s.velocity.values[0] > 0.19)
        assert pad.health().state == HealthState.OK
        plugged[0] = False
        pads[0].gone = True  # pulled out mid-jog
        assert _wait(lambda: pad.health().state == HealthState.MISSING)
        stale = pad.latest()
        time.sleep(0.2)
        assert pad.latest().t == stale.t  # no longer confirmed: it ages
        assert clock() - pad.latest().t >= 0.2
        assert "unplugged" in pad.health().detail
        # plugged in again at the same by-id path: reopened, read again (the sticks at rest now)
        plugged[0] = True
        assert _wait(lambda: len(pads) >= 2 and pad.health().state == HealthState.OK)
        assert pad.health().info["unplugs"] == 1 and pad.health().info["opens"] == 2 and refused[0] >= 2
        assert not pad.latest().deadman and np.all(pad.latest().velocity.values == 0)
    finally:
        pad.disconnect()
    assert all(p.closed for p in pads)


def test_a_pad_without_the_mapped_buttons_is_a_setup_fault():
    def open_device(path: str) -> RecordedPad:
        return RecordedPad([], keys={KEY_CODES["BTN_SOUTH"]})

    pad = EvdevGamepad({"device": "/dev/input/event7", "reopen_s": 5.0}, time.monotonic, open_device=open_device)
    pad.connect()
    try:
        h = pad.health()
        assert h.state == HealthState.FAULT and "has no button" in h.detail and "BTN_TL" in h.detail
        assert pad.latest() is None
    finally:
        pad.disconnect()


def test_a_pad_absent_at_the_start_is_missing_not_an_error():
    def open_device(path: str) -> RecordedPad:
        raise FileNotFoundError(errno.ENOENT, "No such file or directory", path)

    pad = EvdevGamepad({"device": "/dev/input/event9", "reopen_s": 5.0}, time.monotonic, open_device=open_device)
    pad.connect()
    try:
        h = pad.health()
        assert h.state == HealthState.MISSING and "cannot open" in h.detail and pad.latest() is None
    finally:
        pad.disconnect()


@pytest.mark.skipif(not os.path.exists("/dev/uinput"), reason="no /dev/uinput on this machine (kernel without uinput)")
def test_a_real_virtual_pad_through_uinput():
    """Where the kernel has uinput: a virtual pad with the xpad's axes and buttons, read
    by the driver through the real evdev path."""
    import evdev
    from evdev import AbsInfo, UInput, ecodes

    caps = {
        ecodes.EV_KEY: [KEY_CODES[k] for k in ("BTN_SOUTH", "BTN_EAST", "BTN_TL", "BTN_TR", "BTN_SELECT", "BTN_START")],
        ecodes.EV_ABS: [
            (code, AbsInfo(value=0, min=r.minimum, max=r.maximum, fuzz=r.fuzz, flat=r.flat, resolution=0))
            for code, r in XBOX360_RANGES.items()
        ],
    }
    with UInput(caps, name="maris test pad") as ui:
        time.sleep(0.3)  # udev creates the node
        path = next(p for p in evdev.list_devices() if evdev.InputDevice(p).name == "maris test pad")
        pad = EvdevGamepad({"device": path}, time.monotonic)
        pad.connect()
        try:
            ui.write(ecodes.EV_KEY, BTN_TL, 1)
            ui.write(ecodes.EV_ABS, ABS_Y, -32768)
            ui.syn()
            assert _wait(lambda: (s := pad.latest()) is not None and s.deadman and s.velocity.values[0] > 0.19)
        finally:
            pad.disconnect()


# --------------------------------------------------------------------------- pushed inputs


def test_a_pushed_command_is_dated_when_it_was_sent_with_the_link_delay_taken_off():
    now = [100.0]
    wall = [1.7e9]
    inp = PushedInput("foxglove", lambda: now[0], lambda: wall[0])
    inp.push_velocity([0.1, 0, 0, 0, 0, 0])
    assert inp.latest().velocity.t == 100.0
    inp.push_pose(np.eye(4), "map", sent=wall[0] - 2.0)  # sent 2 s ago
    assert inp.latest().pose.t == pytest.approx(98.0) and inp.latest().pose.frame == "map"
    inp.push_point([1, 2, 3], "world", sent=wall[0] + 5.0)  # a clock ahead of ours: no delay
    assert inp.latest().point.t == 100.0 and inp.health().info["future_stamps"] == 1
    inp.press("handback")
    inp.press("handback")
    assert inp.latest().count("handback") == 2 and inp.latest().deadman


def test_a_pushed_input_without_a_comparable_wall_clock_dates_commands_on_arrival():
    inp = PushedInput("foxglove", lambda: 5.0, None)
    inp.push_pose(np.eye(4), "map", sent=12345.0)
    assert inp.latest().pose.t == 5.0


def test_a_pushed_input_refuses_what_is_not_a_command():
    inp = PushedInput("keyboard", lambda: 0.0)
    with pytest.raises(ValueError):
        inp.push_velocity([0.1, 0.2])
    with pytest.raises(ValueError):
        inp.push_pose(np.full((4, 4), np.nan), "map")
    assert inp.latest() is None


# --------------------------------------------------------------------------- the simulator's pad


def test_the_simulators_pad_plays_its_recording_from_the_first_read_and_can_be_unplugged(tmp_path: Path):
    from sim_backend import SimBackend, load_scenario

    rec = write_session(tmp_path / "pad.evemu", [Hold(0.5, {"ABS_Y": -1.0}, ["BTN_TL"])], end_s=2.0)
    scen = load_scenario(
        "pool_clear",
        {"operator.gamepad_recording": str(rec), "operator.gamepad_unplug_s": 3.0},
    )
    sim = SimBackend(scen, 0)
    pad = sim.devices.operators["gamepad"]
    sim.advance(1.0)
    first = pad.latest()  # the recording starts now (t = 1 s)
    assert first.t == pytest.approx(1.0) and not first.deadman
    sim.advance(1.0)
    s = pad.latest()
    assert s.deadman and s.velocity.values[0] > 0.19 and s.t == pytest.approx(2.0)
    sim.advance(1.5)
    assert pad.health().state == HealthState.MISSING
    assert pad.latest().t == pytest.approx(3.0)  # confirmed last when it went
