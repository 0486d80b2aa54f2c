"""A gamepad through the Linux input subsystem (evdev), as an operator input.

The kernel's gamepad drivers (``xpad`` for the Xbox 360 family, ``hid-sony``,
...) turn each USB report into input events: ``EV_ABS`` (an axis moved),
``EV_KEY`` (a button went down (1), up (0), or auto-repeats (2)), and a
``SYN_REPORT`` that closes the packet; an axis or button that does not change
sends nothing, so a stick held still is silent, and the state at open must be
read from the device (``EVIOCGABS``, ``EVIOCGKEY``). When a reader falls behind,
the kernel drops events and says ``SYN_DROPPED``: the reader then ignores every
event up to the next ``SYN_REPORT`` and reads the state from the device again
(the kernel's ``Documentation/input/event-codes.rst``). A device that is
unplugged fails every read with ``ENODEV``. The ``xpad`` sticks report
-32768..32767 with fuzz 16 and flat 128 (its ``xpad_set_up_abs``); a stick's y
axis is negative when pushed up.

* :class:`GamepadDecoder`: packets of events -> the pad's state -> an
  :class:`hal.interfaces.OperatorSample`: each mapped axis, normalised to
  [-1, 1] with the device's dead zone (``flat``), times its scale and the
  full-stick speed, is one component of the command ``[vx vy vz wx wy wz]``; the
  dead-man button must be held; mapped buttons count presses (``handback``,
  ``mode:...``). Pure: the simulator feeds it a recorded stream
  (:mod:`hal.drivers.evemu`), the driver the device's events.
* :class:`EvdevGamepad` (``driver: evdev_gamepad``): opens the device with the
  ``evdev`` package (an optional dependency: ``pip install evdev``), reads it on
  its own thread, and reopens it when it comes back after an unplug (a
  ``/dev/input/by-id/...`` path keeps its name). Its health is MISSING while the
  device is absent; its samples are confirmed at every read that found it
  there, so a pad unplugged mid-jog leaves a sample that ages past the reader's
  dead-man limit.

Times are the backend clock's (s) at the read, not the kernel's event time
(``CLOCK_REALTIME`` by default, another clock).
"""

from __future__ import annotations

import errno
import select
import threading
from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass
from typing import Any, Protocol

import numpy as np

from hal.drivers.evemu import AbsRange, RawEvent
from hal.drivers.realtime import STEP_GATE
from hal.interfaces import Health, HealthState, OperatorInput, OperatorSample, Stamped

EV_SYN, EV_KEY, EV_ABS = 0, 1, 3
SYN_REPORT, SYN_DROPPED = 0, 3

#: Axis codes of ``linux/input-event-codes.h`` a mapping may name.
ABS_CODES: dict[str, int] = {
    "ABS_X": 0x00,
    "ABS_Y": 0x01,
    "ABS_Z": 0x02,
    "ABS_RX": 0x03,
    "ABS_RY": 0x04,
    "ABS_RZ": 0x05,
    "ABS_THROTTLE": 0x06,
    "ABS_RUDDER": 0x07,
    "ABS_HAT0X": 0x10,
    "ABS_HAT0Y": 0x11,
    "ABS_HAT1X": 0x12,
    "ABS_HAT1Y": 0x13,
}
#: Button codes of ``linux/input-event-codes.h`` a mapping may name (joysticks and gamepads).
KEY_CODES: dict[str, int] = {
    **{
        name: 0x120 + i
        for i, name in enumerate(
            (
                "BTN_TRIGGER",
                "BTN_THUMB",
                "BTN_THUMB2",
                "BTN_TOP",
                "BTN_TOP2",
                "BTN_PINKIE",
                "BTN_BASE",
                "BTN_BASE2",
                "BTN_BASE3",
                "BTN_BASE4",
                "BTN_BASE5",
                "BTN_BASE6",
            )
        )
    },
    **{
        name: 0x130 + i
        for i, name in enumerate(
            (
                "BTN_SOUTH",
                "BTN_EAST",
                "BTN_C",
                "BTN_NORTH",
                "BTN_WEST",
                "BTN_Z",
                "BTN_TL",
                "BTN_TR",
                "BTN_TL2",
                "BTN_TR2",
                "BTN_SELECT",
                "BTN_START",
                "BTN_MODE",
                "BTN_THUMBL",
                "BTN_THUMBR",
            )
        )
    },
}
#: The command's components, in ``OperatorSample.velocity`` order.
COMPONENTS = ("vx", "vy", "vz", "wx", "wy", "wz")


@dataclass(frozen=True)
class AxisBinding:
    """Axis ``axis`` (code) drives command component ``component`` (index in
    :data:`COMPONENTS`) with ``scale`` times the full-stick speed at full deflection."""

    axis: int
    component: int
    scale: float


@dataclass(frozen=True)
class GamepadMapping:
    """Which axes drive which components, the dead-man button, the named buttons
    (code -> press name) and the speeds at full deflection (m/s, rad/s)."""

    axes: tuple[AxisBinding, ...]
    deadman: int | None
    buttons: tuple[tuple[int, str], ...]
    max_linear_mps: float = 0.2
    max_angular_rad_s: float = 0.3

    def codes(self) -> tuple[set[int], set[int]]:
        """The axis codes and the button codes this mapping reads."""
        keys = {code for code, _ in self.buttons}
        if self.deadman is not None:
            keys.add(self.deadman)
        return {b.axis for b in self.axes}, keys


#: The default axes (component -> axis name, scale) for an Xbox 360 pad on ``xpad``:
#: left stick forward/right (x, y), right stick up/down (z) and turn (yaw rate), d-pad
#: roll and pitch. Stick y axes are negative when pushed up, hence the signs.
DEFAULT_AXES: dict[str, tuple[str, float]] = {
    "vx": ("ABS_Y", -1.0),
    "vy": ("ABS_X", 1.0),
    "vz": ("ABS_RY", 1.0),
    "wx": ("ABS_HAT0X", 1.0),
    "wy": ("ABS_HAT0Y", -1.0),
    "wz": ("ABS_RX", 1.0),
}
#: Default buttons (name -> press): start hands control back, A/B choose the tool or
#: the vehicle jog, back toggles the tool jog's axes (world/vehicle), the right bumper
#: cancels a goal. The dead-man is the left bumper (``BTN_TL``), held.
DEFAULT_BUTTONS: dict[str, str] = {
    "BTN_START": "handback",
    "BTN_SOUTH": "mode:tool_velocity",
    "BTN_EAST": "mode:vehicle_velocity",
    "BTN_SELECT": "frame:toggle",
    "BTN_TR": "stop",
}
DEFAULT_DEADMAN = "BTN_TL"
#: The axes of an Xbox 360 pad as ``xpad`` declares them (``xpad_set_up_abs``): sticks
#: -32768..32767 (fuzz 16, flat 128), triggers 0..255, d-pad -1..1 (when mapped to axes).
XBOX360_RANGES: dict[int, AbsRange] = {
    **{ABS_CODES[a]: AbsRange(-32768, 32767, 16, 128) for a in ("ABS_X", "ABS_Y", "ABS_RX", "ABS_RY")},
    **{ABS_CODES[a]: AbsRange(0, 255) for a in ("ABS_Z", "ABS_RZ")},
    **{ABS_CODES[a]: AbsRange(-1, 1) for a in ("ABS_HAT0X", "ABS_HAT0Y")},
}


def gamepad_mapping(params: Mapping[str, Any] | None = None) -> GamepadMapping:
    """The mapping of a HAL config's ``evdev_gamepad`` (or ``sim``) parameters; defaults
    above. ValueError naming the field for an unknown axis, button or component."""
    p = dict(params or {})
    axes_spec = p.get("axes") or {k: {"axis": a, "scale": s} for k, (a, s) in DEFAULT_AXES.items()}
    axes = []
    for comp, spec in axes_spec.items():
        if comp not in COMPONENTS:
            raise ValueError(f"axes.{comp}: unknown component (one of {', '.join(COMPONENTS)})")
        name = spec["axis"]
        if name not in ABS_CODES:
            raise ValueError(f"axes.{comp}.axis: unknown axis {name!r} (one of {', '.join(ABS_CODES)})")
        axes.append(AxisBinding(ABS_CODES[name], COMPONENTS.index(comp), float(spec.get("scale", 1.0))))
    buttons = []
    for key, press in (p.get("buttons") or DEFAULT_BUTTONS).items():
        if key not in KEY_CODES:
            raise ValueError(f"buttons.{key}: unknown button (one of {', '.join(KEY_CODES)})")
        buttons.append((KEY_CODES[key], str(press)))
    deadman_name = p.get("deadman_button", DEFAULT_DEADMAN)
    if deadman_name is not None and deadman_name not in KEY_CODES:
        raise ValueError(f"deadman_button: unknown button {deadman_name!r} (one of {', '.join(KEY_CODES)})")
    return GamepadMapping(
        axes=tuple(axes),
        deadman=None if deadman_name is None else KEY_CODES[deadman_name],
        buttons=tuple(buttons),
        max_linear_mps=float(p.get("max_linear_mps", 0.2)),
        max_angular_rad_s=float(p.get("max_angular_rad_s", 0.3)),
    )


def normalized(value: int, r: AbsRange) -> float:
    """An axis value as a fraction of full deflection: [-1, 1] about the centre of a
    two-sided axis (0 within ``flat`` of it), [0, 1] from the minimum of a one-sided
    one (a trigger: minimum >= 0 and no dead zone)."""
    if r.minimum >= 0 and r.flat == 0:
        return min(1.0, max(0.0, (value - r.minimum) / (r.maximum - r.minimum)))
    centre = 0.5 * (r.minimum + r.maximum)
    half = 0.5 * (r.maximum - r.minimum)
    offset = value - centre
    if abs(offset) <= r.flat:
        return 0.0
    return min(1.0, max(-1.0, offset / half))


class GamepadDecoder:
    """The pad's state from its event packets (see the module docstring)."""

    def __init__(self, mapping: GamepadMapping, ranges: Mapping[int, AbsRange]) -> None:
        missing = sorted(b.axis for b in mapping.axes if b.axis not in ranges)
        if missing:
            names = {v: k for k, v in ABS_CODES.items()}
            raise ValueError(f"the device has no axis {', '.join(names.get(c, hex(c)) for c in missing)}")
        self.mapping = mapping
        self.ranges = dict(ranges)
        self._axes: dict[int, int] = {b.axis: rest_value(ranges[b.axis]) for b in mapping.axes}
        self._keys: set[int] = set()
        self._pending: list[RawEvent] = []
        self._dropping = False
        self._names = dict(mapping.buttons)
        #: press name -> count
        self.presses: dict[str, int] = {}
        #: SYN_DROPPED packets seen (events the kernel lost)
        self.drops = 0
        #: True after a SYN_DROPPED until :meth:`set_state` reads the device again
        self.needs_resync = False

    def set_state(self, axes: Mapping[int, int], keys_down: Iterable[int]) -> None:
        """The device's state as read from it (at open, or after a drop): axis values and
        the buttons held. A button found held counts no press (its press was not seen)."""
        for code in self._axes:
            if code in axes:
                self._axes[code] = int(axes[code])
        self._keys = set(keys_down)
        self._pending.clear()
        self._dropping = False
        self.needs_resync = False

    def feed(self, ev: RawEvent) -> bool:
        """Take one event; True when it completed a packet (the state changed as one)."""
        if ev.type == EV_SYN:
            if ev.code == SYN_DROPPED:
                self._dropping = True
                self.needs_resync = True
                self.drops += 1
                self._pending.clear()
                return False
            if ev.code == SYN_REPORT:
                if self._dropping:  # the packet the drop cut: discard it, then start afresh
                    self._dropping = False
                    self._pending.clear()
                    return False
                self._commit()
                return True
            return False
        if not self._dropping and ev.type in (EV_ABS, EV_KEY):
            self._pending.append(ev)
        return False

    def _commit(self) -> None:
        for ev in self._pending:
            if ev.type == EV_ABS:
                if ev.code in self._axes:
                    self._axes[ev.code] = ev.value
            elif ev.value == 1:  # down (2 is the auto-repeat of a held key: not a new press)
                if ev.code not in self._keys:
                    name = self._names.get(ev.code)
                    if name is not None:
                        self.presses[name] = self.presses.get(name, 0) + 1
                self._keys.add(ev.code)
            elif ev.value == 0:
                self._keys.discard(ev.code)
        self._pending.clear()

    def command(self) -> np.ndarray:
        """The command ``[vx vy vz wx wy wz]`` (m/s, rad/s) of the current stick positions."""
        m = self.mapping
        v = np.zeros(6)
        for b in m.axes:
            full = m.max_linear_mps if b.component < 3 else m.max_angular_rad_s
            v[b.component] += b.scale * full * normalized(self._axes[b.axis], self.ranges[b.axis])
        return v

    @property
    def deadman(self) -> bool:
        """The dead-man button is held (True when the mapping has none)."""
        return self.mapping.deadman is None or self.mapping.deadman in self._keys

    def sample(self, t: float) -> OperatorSample:
        """The state at ``t`` (s): the time it was last confirmed."""
        return OperatorSample(
            t=t, deadman=self.deadman, velocity=Stamped(t, self.command()), presses=dict(self.presses)
        )


def rest_value(r: AbsRange) -> int:
    """An axis's value at rest: its centre, or the minimum of a one-sided axis (a trigger)."""
    if r.minimum >= 0 and r.flat == 0:
        return r.minimum
    return int(round(0.5 * (r.minimum + r.maximum)))


# --------------------------------------------------------------------------- the device


class InputDeviceLike(Protocol):
    """What :class:`EvdevGamepad` uses of an opened input device (:class:`EvdevDevice`)."""

    name: str

    def fileno(self) -> int: ...

    def ranges(self) -> dict[int, AbsRange]: ...

    def state(self) -> tuple[dict[int, int], set[int]]: ...

    def key_codes(self) -> set[int]: ...

    def read_events(self) -> list[RawEvent]: ...

    def close(self) -> None: ...


class EvdevDevice:
    """An input device opened with the ``evdev`` package (``/dev/input/eventN``)."""

    def __init__(self, path: str, grab: bool = False) -> None:
        try:
            import evdev  # optional: the gamepad extra (pip install evdev)
        except ImportError as exc:  # pragma: no cover - depends on the environment
            raise RuntimeError("the evdev_gamepad driver needs the evdev package: pip install evdev") from exc
        self._dev = evdev.InputDevice(path)
        self.name: str = self._dev.name
        if grab:
            self._dev.grab()  # EVIOCGRAB: this process alone gets the events

    def fileno(self) -> int:
        return int(self._dev.fd)

    def ranges(self) -> dict[int, AbsRange]:
        caps: dict[int, list[Any]] = self._dev.capabilities(absinfo=True)
        out: dict[int, AbsRange] = {}
        for code, a in caps.get(EV_ABS, []):
            out[int(code)] = AbsRange(int(a.min), int(a.max), int(a.fuzz), int(a.flat), int(a.resolution))
        return out

    def key_codes(self) -> set[int]:
        return {int(k) for k in self._dev.capabilities().get(EV_KEY, [])}

    def state(self) -> tuple[dict[int, int], set[int]]:
        axes = {code: int(self._dev.absinfo(code).value) for code in self.ranges()}
        return axes, {int(k) for k in self._dev.active_keys()}

    def read_events(self) -> list[RawEvent]:
        out: list[RawEvent] = []
        while True:
            ev = self._dev.read_one()
            if ev is None:
                return out
            out.append(RawEvent(ev.timestamp(), int(ev.type), int(ev.code), int(ev.value)))

    def close(self) -> None:
        self._dev.close()


class EvdevGamepad(OperatorInput):
    """A gamepad on the Linux input subsystem (see the module docstring).

    params (``hal.config_schema``): ``device`` (its ``/dev/input/...`` path), the mapping
    (``axes``, ``buttons``, ``deadman_button``, ``max_linear_mps``, ``max_angular_rad_s``),
    ``grab``, ``reopen_s`` (s between attempts to open an absent device) and ``timeout_s``
    (the reader's watchdog: its last confirmation older than that is a FAULT).
    ``open_device(path)`` opens the device (default :class:`EvdevDevice`)."""

    name = "gamepad"

    def __init__(
        self,
        params: Mapping[str, Any],
        clock: Callable[[], float],
        *,
        open_device: Callable[[str], InputDeviceLike] | None = None,
    ) -> None:
        self.path = str(params["device"])
        self.mapping = gamepad_mapping(params)
        self.grab = bool(params.get("grab", False))
        self.reopen_s = float(params.get("reopen_s", 1.0))
        self.timeout_s = float(params.get("timeout_s", 0.5))
        self._now = clock
        self._open = open_device or (lambda path: EvdevDevice(path, self.grab))
        self._lock = threading.Lock()
        self._decoder: GamepadDecoder | None = None
        self._dev: InputDeviceLike | None = None
        self._confirmed: float | None = None  # backend time of the last read that found the device
        self._problem = "not opened yet"
        self._lost = ""  # why an opened device went away, until it is open again
        self._setup_error: str | None = None
        self._opens = 0
        self._unplugs = 0
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None

    # ------------------------------------------------------------------ life cycle
    def connect(self) -> None:
        """Open the device now if it is there (else keep trying) and start reading it."""
        self._try_open()
        if self._thread is None:
            self._stop.clear()
            self._thread = threading.Thread(target=self._run, name="maris-gamepad", daemon=True)
            self._thread.start()

    def disconnect(self) -> None:
        self._stop.set()
        if self._thread is not None:
            self._thread.join(timeout=2.0)
            self._thread = None
        with self._lock:
            self._close_device("closed")

    # ------------------------------------------------------------------ readings
    def latest(self) -> OperatorSample | None:
        with self._lock:
            if self._decoder is None or self._confirmed is None:
                return None
            return self._decoder.sample(self._confirmed)

    def health(self) -> Health:
        now = self._now()
        with self._lock:
            info: dict[str, Any] = {"device": self.path, "opens": self._opens, "unplugs": self._unplugs}
            if self._decoder is not None:
                info["drops"] = self._decoder.drops
            if self._setup_error is not None:
                return Health(HealthState.FAULT, now, self._setup_error, info)
            if self._dev is None:
                return Health(HealthState.MISSING, now, f"gamepad {self.path}: {self._problem}", info)
            age = None if self._confirmed is None else now - self._confirmed
            info["age_s"] = age
            if age is None or age > self.timeout_s:
                return Health(HealthState.FAULT, now, f"gamepad {self.path}: not read for {age} s", info)
            return Health(HealthState.OK, now, "", info)

    # ------------------------------------------------------------------ reader thread
    def _try_open(self) -> None:
        try:
            dev = self._open(self.path)
        except OSError as exc:
            with self._lock:
                lost = f"{self._lost}; " if self._lost else ""
                self._problem = f"{lost}cannot open: {exc.strerror or exc}"
            return
        try:
            decoder = GamepadDecoder(self.mapping, dev.ranges())
            missing_keys = self._missing_buttons(dev)
            if missing_keys:
                raise ValueError(f"the device has no button {', '.join(missing_keys)}")
            axes, keys = dev.state()
        except ValueError as exc:  # the mapping does not fit this device: a set-up error
            dev.close()
            with self._lock:
                self._setup_error = f"gamepad {self.path} ({dev.name}): {exc}"
            return
        except OSError as exc:
            dev.close()
            with self._lock:
                self._problem = f"cannot read its state: {exc.strerror or exc}"
            return
        decoder.set_state(axes, keys)
        with self._lock:
            if self._decoder is not None:  # a reopened pad keeps counting presses where it was
                decoder.presses = dict(self._decoder.presses)
                decoder.drops = self._decoder.drops
            self._dev, self._decoder = dev, decoder
            self._confirmed = self._now()
            self._opens += 1
            self._setup_error = None
            self._lost = ""

    def _missing_buttons(self, dev: InputDeviceLike) -> list[str]:
        """Mapped buttons the device lacks."""
        have = dev.key_codes()
        _, keys = self.mapping.codes()
        names = {v: k for k, v in KEY_CODES.items()}
        return sorted(names.get(k, hex(k)) for k in keys if k not in have)

    def _close_device(self, why: str) -> None:
        """Under the lock."""
        if self._dev is not None:
            try:
                self._dev.close()
            except OSError:
                pass
        self._dev = None
        self._problem = why

    def _run(self) -> None:
        while not self._stop.is_set():
            dev = self._dev
            if dev is None:  # absent, or not fit for the mapping: try again later
                if not self._stop.wait(self.reopen_s):
                    self._try_open()
                continue
            try:
                ready = select.select([dev.fileno()], [], [], 0.05)[0]
                events = dev.read_events() if ready else []
            except OSError as exc:
                with self._lock:
                    if exc.errno == errno.ENODEV:
                        self._unplugs += 1
                        self._lost = "unplugged (the device is gone)"
                        self._close_device(self._lost)
                    else:
                        self._close_device(f"read failed: {exc.strerror or exc}")
                continue
            if events:
                STEP_GATE.wait()  # decode after the control loop's step, not during it
            resync = False
            with self._lock:
                decoder = self._decoder
                if decoder is None:
                    continue
                for ev in events:
                    decoder.feed(ev)
                resync = decoder.needs_resync
                self._confirmed = self._now()
            if resync:
                try:
                    axes, keys = dev.state()
                except OSError:
                    continue  # the next read says what happened
                with self._lock:
                    decoder.set_state(axes, keys)
