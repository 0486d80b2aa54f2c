"""The CiA 402 (IEC 61800-7-201) power state machine, shared by host and drive.

One transition table (:data:`TRANSITIONS`) serves three purposes:

* :class:`Cia402Machine` (a ``transitions`` state machine) is the *device side*:
  the drive simulator feeds it controlwords and reads back the statusword;
* :func:`next_command` is the *host side* planner: the shortest command path from
  the drive's reported state to the wanted one, leaving OPERATION ENABLED only
  through QUICK STOP ACTIVE (the safe way down: quick stop, then
  switch-on-disabled);
* :func:`decode_statusword` / :data:`CONTROLWORD` translate to and from the bits.

Statusword bits: 0 ready to switch on, 1 switched on, 2 operation enabled,
3 fault, 4 voltage enabled, 5 quick stop (0 = active), 6 switch on disabled,
7 warning, 9 remote, 10 target reached. Controlword bits: 0 switch on,
1 enable voltage, 2 quick stop (0 = active), 3 enable operation, 7 fault reset
(acts on the rising edge).
"""

from __future__ import annotations

import enum
from collections import deque
from collections.abc import Callable
from typing import TYPE_CHECKING

from transitions import Machine

if TYPE_CHECKING:  # a name of the package's type stubs only
    from transitions.core import TransitionConfigDict


class State(str, enum.Enum):  # noqa: UP042 - str() of a member is used in messages
    NOT_READY_TO_SWITCH_ON = "NOT READY TO SWITCH ON"
    SWITCH_ON_DISABLED = "SWITCH ON DISABLED"
    READY_TO_SWITCH_ON = "READY TO SWITCH ON"
    SWITCHED_ON = "SWITCHED ON"
    OPERATION_ENABLED = "OPERATION ENABLED"
    QUICK_STOP_ACTIVE = "QUICK STOP ACTIVE"
    FAULT_REACTION_ACTIVE = "FAULT REACTION ACTIVE"
    FAULT = "FAULT"


S = State

#: Controlword of each host command (bit 7 of fault_reset must see a rising edge).
CONTROLWORD: dict[str, int] = {
    "shutdown": 0x06,
    "switch_on": 0x07,
    "disable_operation": 0x07,
    "enable_operation": 0x0F,
    "disable_voltage": 0x00,
    "quick_stop": 0x02,
    "fault_reset": 0x80,
}

#: (trigger, source, destination), in the order the host planner prefers them.
#: Transition numbers of the standard in comments.
TRANSITIONS: list[tuple[str, State, State]] = [
    ("quick_stop", S.OPERATION_ENABLED, S.QUICK_STOP_ACTIVE),  # 11
    ("disable_voltage", S.QUICK_STOP_ACTIVE, S.SWITCH_ON_DISABLED),  # 12
    ("enable_operation", S.QUICK_STOP_ACTIVE, S.OPERATION_ENABLED),  # 16
    ("fault_reset", S.FAULT, S.SWITCH_ON_DISABLED),  # 15
    ("shutdown", S.SWITCH_ON_DISABLED, S.READY_TO_SWITCH_ON),  # 2
    ("switch_on", S.READY_TO_SWITCH_ON, S.SWITCHED_ON),  # 3
    ("enable_operation", S.SWITCHED_ON, S.OPERATION_ENABLED),  # 4
    ("disable_operation", S.OPERATION_ENABLED, S.SWITCHED_ON),  # 5
    ("shutdown", S.SWITCHED_ON, S.READY_TO_SWITCH_ON),  # 6
    ("disable_voltage", S.READY_TO_SWITCH_ON, S.SWITCH_ON_DISABLED),  # 7
    ("quick_stop", S.READY_TO_SWITCH_ON, S.SWITCH_ON_DISABLED),  # 7
    ("shutdown", S.OPERATION_ENABLED, S.READY_TO_SWITCH_ON),  # 8
    ("disable_voltage", S.OPERATION_ENABLED, S.SWITCH_ON_DISABLED),  # 9 (the planner avoids it)
    ("disable_voltage", S.SWITCHED_ON, S.SWITCH_ON_DISABLED),  # 10
    ("quick_stop", S.SWITCHED_ON, S.SWITCH_ON_DISABLED),  # 10
]
#: Device-internal transitions (not commanded by the host).
INTERNAL: list[tuple[str, State | list[State], State]] = [
    ("init_done", S.NOT_READY_TO_SWITCH_ON, S.SWITCH_ON_DISABLED),  # 1
    ("fault", [s for s in S if s not in (S.FAULT, S.FAULT_REACTION_ACTIVE)], S.FAULT_REACTION_ACTIVE),  # 13
    ("fault_reaction_done", S.FAULT_REACTION_ACTIVE, S.FAULT),  # 14
]
_PLANNER_AVOIDS = {("disable_voltage", S.OPERATION_ENABLED)}

_STATUS_PATTERNS: list[tuple[int, int, State]] = [
    (0x4F, 0x00, S.NOT_READY_TO_SWITCH_ON),
    (0x4F, 0x40, S.SWITCH_ON_DISABLED),
    (0x6F, 0x21, S.READY_TO_SWITCH_ON),
    (0x6F, 0x23, S.SWITCHED_ON),
    (0x6F, 0x27, S.OPERATION_ENABLED),
    (0x6F, 0x07, S.QUICK_STOP_ACTIVE),
    (0x4F, 0x0F, S.FAULT_REACTION_ACTIVE),
    (0x4F, 0x08, S.FAULT),
]
_STATUS_BITS: dict[State, int] = {
    S.NOT_READY_TO_SWITCH_ON: 0x00,
    S.SWITCH_ON_DISABLED: 0x40,
    S.READY_TO_SWITCH_ON: 0x21,
    S.SWITCHED_ON: 0x23,
    S.OPERATION_ENABLED: 0x27,
    S.QUICK_STOP_ACTIVE: 0x07,
    S.FAULT_REACTION_ACTIVE: 0x0F,
    S.FAULT: 0x08,
}
SW_VOLTAGE_ENABLED = 0x10
SW_QUICK_STOP = 0x20  # 1 = quick stop NOT active
SW_WARNING = 0x80
SW_REMOTE = 0x200
SW_TARGET_REACHED = 0x400


def decode_statusword(sw: int) -> State | None:
    """CiA 402 state encoded in a statusword, None if the bit pattern is invalid."""
    for mask, value, state in _STATUS_PATTERNS:
        if sw & mask == value:
            return state
    return None


def encode_statusword(state: State, *, remote: bool = True, target_reached: bool = False, warning: bool = False) -> int:
    """Statusword a drive reports in ``state`` (voltage-enabled and quick-stop bits set as usual)."""
    sw = _STATUS_BITS[state]
    if state in (S.READY_TO_SWITCH_ON, S.SWITCHED_ON, S.OPERATION_ENABLED, S.FAULT_REACTION_ACTIVE, S.FAULT):
        sw |= SW_VOLTAGE_ENABLED
    if state in (S.READY_TO_SWITCH_ON, S.SWITCHED_ON, S.OPERATION_ENABLED):
        sw |= SW_QUICK_STOP
    return (
        sw
        | (SW_REMOTE if remote else 0)
        | (SW_TARGET_REACHED if target_reached else 0)
        | (SW_WARNING if warning else 0)
    )


def command_of_controlword(cw: int, previous_cw: int = 0) -> str | None:
    """Which device command a controlword carries (None: no state command).

    A fault reset needs bit 7 rising; otherwise bits 0-3 select the command.
    "switch_on" stands for both switch on and disable operation (same bits);
    "enable_operation" for 0x0F.
    """
    if cw & 0x80 and not previous_cw & 0x80:
        return "fault_reset"
    if cw & 0x02 == 0:
        return "disable_voltage"
    if cw & 0x06 == 0x02:
        return "quick_stop"
    low = cw & 0x0F
    if low in (0x06, 0x0E):
        return "shutdown"
    if low == 0x07:
        return "switch_on"
    if low == 0x0F:
        return "enable_operation"
    return None


def next_command(current: State, target: State) -> str | None:
    """First host command on the shortest allowed path from ``current`` to ``target``.

    None when already there or no path exists (e.g. from FAULT REACTION ACTIVE,
    which the drive leaves by itself). Leaving OPERATION ENABLED towards a
    disabled state always goes through QUICK STOP ACTIVE.
    """
    if current == target:
        return None
    first: dict[State, str] = {}
    queue: deque[State] = deque([current])
    seen = {current}
    while queue:
        s = queue.popleft()
        for trig, src, dst in TRANSITIONS:
            if src != s or dst in seen or (trig, src) in _PLANNER_AVOIDS:
                continue
            seen.add(dst)
            first[dst] = first.get(s, trig)
            if dst == target:
                return first[dst]
            queue.append(dst)
    return None


class Cia402Machine:
    """Device-side CiA 402 state machine (used by the drive simulator).

    Feed it controlwords with :meth:`apply_controlword`; internal events with
    :meth:`raise_fault` / :meth:`fault_reaction_done`; read :attr:`statusword`.
    """

    #: Fires a transition by its trigger's name (added by ``transitions``' ``Machine``).
    trigger: Callable[[str], bool]

    def __init__(self) -> None:
        self.state: str = S.NOT_READY_TO_SWITCH_ON.value
        self._last_cw = 0
        device_transitions: list[TransitionConfigDict] = [
            {
                "trigger": "switch_on_or_disable_operation",
                "source": S.READY_TO_SWITCH_ON.value,
                "dest": S.SWITCHED_ON.value,
            },
            {
                "trigger": "switch_on_or_disable_operation",
                "source": S.OPERATION_ENABLED.value,
                "dest": S.SWITCHED_ON.value,
            },
            {
                "trigger": "enable_operation",
                "source": S.READY_TO_SWITCH_ON.value,
                "dest": S.OPERATION_ENABLED.value,
            },  # 3 + 4
        ]
        for trig, src, dst in TRANSITIONS:
            if trig in ("switch_on", "disable_operation"):
                continue
            device_transitions.append({"trigger": trig, "source": src.value, "dest": dst.value})
        for trig, sources, dst in INTERNAL:
            srcs = [s.value for s in sources] if isinstance(sources, list) else sources.value
            device_transitions.append({"trigger": trig, "source": srcs, "dest": dst.value})
        self._machine = Machine(
            model=self,
            states=[s.value for s in S],
            transitions=device_transitions,
            initial=S.NOT_READY_TO_SWITCH_ON.value,
            ignore_invalid_triggers=True,
            auto_transitions=False,
        )

    @property
    def cia_state(self) -> State:
        return State(self.state)

    @property
    def statusword(self) -> int:
        return encode_statusword(self.cia_state)

    def apply_controlword(self, cw: int) -> State:
        """Act on a received controlword; returns the new state."""
        cmd = command_of_controlword(cw, self._last_cw)
        self._last_cw = cw
        if cmd == "switch_on":
            cmd = "switch_on_or_disable_operation"
        if cmd is not None:
            self._fire(cmd)
        return self.cia_state

    def _fire(self, trigger: str) -> None:
        # commands that do not apply in the current state are ignored, as on a real drive
        if trigger in self._machine.get_triggers(self.state):
            self.trigger(trigger)

    def raise_fault(self) -> None:
        self._fire("fault")

    def fault_reaction_done(self) -> None:
        self._fire("fault_reaction_done")

    def boot(self) -> None:
        self._fire("init_done")
