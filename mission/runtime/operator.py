"""Operator control while a mission runs: keys, signals, scripted commands.

Commands are the strings ``pause``, ``resume``, ``abort`` (and ``stop_now``
for a second interrupt: skip the abort path, safe-stop at once).

* :class:`KeyReader`: single keys from a terminal in cbreak mode, polled without
  blocking (``p`` pause, ``r`` resume, space toggles, ``a``/``q`` abort). Used
  only when stdin is a TTY; the terminal is restored on close.
* :class:`SignalAbort`: SIGINT/SIGTERM -> ``abort`` (again -> ``stop_now``);
  previous handlers restored on close.
* :class:`ScriptedOperator`: commands at given backend times (tests, campaigns).
"""

from __future__ import annotations

import os
import select
import signal
import sys
import termios
import tty
from collections import deque
from collections.abc import Callable, Iterable
from types import FrameType
from typing import Any, NamedTuple, Protocol, TextIO

#: What ``signal.signal`` returns: the previous handler of a signal.
SignalHandler = Callable[[int, FrameType | None], object] | int | signal.Handlers | None

KEYMAP = {"p": "pause", "r": "resume", " ": "toggle", "a": "abort", "q": "abort"}
KEY_HELP = "keys: p pause, r resume, space toggle, a/q abort"
#: Teleop keys (with a ``keyboard`` operator input): key -> (command component, sign); components
#: ``[vx vy vz wx wy wz]`` (m/s, rad/s; axes: the teleop mode's). i/k forward/back, j/l left/right,
#: u/o up/down (NED: up is -z), n/m turn left/right.
JOG_KEYS: dict[str, tuple[int, float]] = {
    "i": (0, 1.0),
    "k": (0, -1.0),
    "l": (1, 1.0),
    "j": (1, -1.0),
    "o": (2, 1.0),
    "u": (2, -1.0),
    "m": (5, 1.0),
    "n": (5, -1.0),
}
#: Teleop buttons: h hands back, t/v the tool/vehicle jog, f the tool jog's axes, x stops a goal.
BUTTON_KEYS = {
    "h": "handback",
    "t": "mode:tool_velocity",
    "v": "mode:vehicle_velocity",
    "f": "frame:toggle",
    "x": "stop",
}
#: Speeds of a jog key: linear m/s, angular rad/s.
KEY_SPEED = (0.1, 0.2)
TELEOP_KEY_HELP = "teleop keys (hold): i/k fwd/back, j/l left/right, u/o up/down, n/m turn; h hand back, t/v tool/vehicle, f axes, x stop"


class OperatorCommand(NamedTuple):
    """One operator request: ``command`` (``pause``, ``resume``, ``toggle``, ``abort``,
    ``stop_now``) and where it came from (``key 'p'``, ``SIGINT``, ``script @ 3 s``...)."""

    command: str
    source: str


class Commands(Protocol):
    """A queue of operator commands (:class:`CommandQueue`, or a recording or replaying one)."""

    def put(self, command: str, source: str) -> None: ...

    def drain(self) -> list[OperatorCommand]: ...


class CommandQueue:
    """Pending operator commands, oldest first (signal-handler safe: deque appends)."""

    def __init__(self) -> None:
        self._q: deque[OperatorCommand] = deque()

    def put(self, command: str, source: str) -> None:
        self._q.append(OperatorCommand(command, source))

    def drain(self) -> list[OperatorCommand]:
        out = []
        while self._q:
            out.append(self._q.popleft())
        return out


class KeyReader:
    """Non-blocking single-key reader on a TTY stdin."""

    def __init__(self, queue: Commands, stream: TextIO | None = None) -> None:
        self.queue = queue
        #: The run's ``keyboard`` operator input (:meth:`attach_input`): teleop keys go there.
        self.operator_input: Any = None
        self.stream = stream or sys.stdin
        self._fd = self.stream.fileno()
        self._saved: list | None = termios.tcgetattr(self._fd)
        tty.setcbreak(self._fd)

    def attach_input(self, device: Any) -> None:
        """Send the teleop keys to ``device`` (a :class:`hal.drivers.pushed_input.PushedInput`):
        a jog key pushes a velocity (held down, the terminal's auto-repeat keeps it fresh), a
        button key a press."""
        self.operator_input = device

    def poll(self) -> None:
        """Read whatever keys are waiting, never blocking."""
        while select.select([self._fd], [], [], 0)[0]:
            ch = os.read(self._fd, 1).decode(errors="ignore").lower()
            if not ch:
                break
            cmd = KEYMAP.get(ch)
            if cmd:
                self.queue.put(cmd, f"key {ch!r}")
            elif self.operator_input is not None:
                self._teleop_key(ch)

    def _teleop_key(self, ch: str) -> None:
        jog = JOG_KEYS.get(ch)
        if jog is not None:
            component, sign = jog
            v = [0.0] * 6
            v[component] = sign * KEY_SPEED[0 if component < 3 else 1]
            self.operator_input.push_velocity(v)
        elif ch in BUTTON_KEYS:
            self.operator_input.press(BUTTON_KEYS[ch])

    def close(self) -> None:
        if self._saved is not None:
            termios.tcsetattr(self._fd, termios.TCSADRAIN, self._saved)
            self._saved = None


class SignalAbort:
    """SIGINT/SIGTERM request an abort; a second one requests ``stop_now``."""

    def __init__(self, queue: Commands, signals: Iterable[int] = (signal.SIGINT, signal.SIGTERM)) -> None:
        self.queue = queue
        self.count = 0
        self._previous: dict[int, SignalHandler] = {}
        for s in signals:
            self._previous[s] = signal.signal(s, self._handle)

    def _handle(self, signum: int, frame: FrameType | None) -> None:
        self.count += 1
        name = signal.Signals(signum).name
        self.queue.put("abort" if self.count == 1 else "stop_now", name)

    def close(self) -> None:
        for s, h in self._previous.items():
            signal.signal(s, h)
        self._previous.clear()


class ScriptStep(NamedTuple):
    """A scripted command ``command`` at backend time ``t`` (s)."""

    t: float
    command: str


class ScriptedOperator:
    """Commands issued at backend times: ``[(t_s, "pause"), (t_s, "resume")]``."""

    def __init__(self, queue: Commands, script: Iterable[tuple[float, str]]) -> None:
        self.queue = queue
        self._pending = sorted(ScriptStep(t, cmd) for t, cmd in script)

    def poll(self, now: float) -> None:
        while self._pending and self._pending[0].t <= now:
            step = self._pending.pop(0)
            self.queue.put(step.command, f"script @ {step.t:g} s")
