"""CiA 402 state machine: bit patterns, device machine, host planner."""

from __future__ import annotations

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from hal.drivers.cia402 import CONTROLWORD, Cia402Machine, State, decode_statusword, encode_statusword, next_command

S = State


@pytest.mark.parametrize("state", list(State))
def test_statusword_roundtrip(state: State) -> None:
    for flags in ({}, {"warning": True}, {"target_reached": True}, {"remote": False}):
        assert decode_statusword(encode_statusword(state, **flags)) == state


def test_statusword_examples_from_the_standard() -> None:
    assert decode_statusword(0x0250) == S.SWITCH_ON_DISABLED
    assert decode_statusword(0x0231) == S.READY_TO_SWITCH_ON
    assert decode_statusword(0x0233) == S.SWITCHED_ON
    assert decode_statusword(0x0637) == S.OPERATION_ENABLED
    assert decode_statusword(0x0217) == S.QUICK_STOP_ACTIVE  # bit 5 low
    assert decode_statusword(0x0218) == S.FAULT
    assert decode_statusword(0x0228) == S.FAULT
    assert decode_statusword(0x0061) is None  # SOD + ready bit: invalid


def test_enable_sequence_and_fault_reset_edge() -> None:
    m = Cia402Machine()
    m.boot()
    assert [m.apply_controlword(cw) for cw in (0x06, 0x07, 0x0F)] == [
        S.READY_TO_SWITCH_ON,
        S.SWITCHED_ON,
        S.OPERATION_ENABLED,
    ]
    m.raise_fault()
    assert m.cia_state == S.FAULT_REACTION_ACTIVE
    m.fault_reaction_done()
    assert m.apply_controlword(0x80) == S.SWITCH_ON_DISABLED
    m.raise_fault()
    m.fault_reaction_done()
    assert m.apply_controlword(0x80) == S.FAULT  # bit 7 still high: no rising edge
    assert m.apply_controlword(0x00) == S.FAULT
    assert m.apply_controlword(0x80) == S.SWITCH_ON_DISABLED


def test_quick_stop_is_the_way_down() -> None:
    assert next_command(S.OPERATION_ENABLED, S.SWITCH_ON_DISABLED) == "quick_stop"
    assert next_command(S.QUICK_STOP_ACTIVE, S.SWITCH_ON_DISABLED) == "disable_voltage"
    assert next_command(S.FAULT, S.OPERATION_ENABLED) == "fault_reset"
    assert next_command(S.SWITCH_ON_DISABLED, S.OPERATION_ENABLED) == "shutdown"
    assert next_command(S.OPERATION_ENABLED, S.OPERATION_ENABLED) is None
    assert next_command(S.FAULT_REACTION_ACTIVE, S.OPERATION_ENABLED) is None


reachable = st.sampled_from([s for s in State if s not in (S.NOT_READY_TO_SWITCH_ON, S.FAULT_REACTION_ACTIVE, S.FAULT)])


@settings(max_examples=80, deadline=None)
@given(
    start_cws=st.lists(st.sampled_from([0x00, 0x02, 0x06, 0x07, 0x0F, 0x80, 0x8F, 0x0B, 0x03]), max_size=8),
    fault=st.booleans(),
    target=reachable,
)
def test_planner_drives_the_device_machine_to_any_target(start_cws: list[int], fault: bool, target: State) -> None:
    """Whatever the drive went through, following the planner reaches the target
    in a few steps, and every reported statusword decodes to the device state."""
    m = Cia402Machine()
    m.boot()
    for cw in start_cws:
        m.apply_controlword(cw)
        assert decode_statusword(m.statusword) == m.cia_state
    if fault:
        m.raise_fault()
        m.fault_reaction_done()
    last = 0
    for _ in range(8):
        cmd = next_command(m.cia_state, target)
        if cmd is None:
            break
        cw = CONTROLWORD[cmd]
        if cmd == "fault_reset" and last & 0x80:
            cw = 0
        m.apply_controlword(cw)
        last = cw
    assert m.cia_state == target
