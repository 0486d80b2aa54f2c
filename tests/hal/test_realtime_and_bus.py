"""Wall-clock pacing and the CAN echo filter."""

from __future__ import annotations

import random

import can
import pytest

from hal.drivers.canbus import open_can_bus
from hal.drivers.realtime import MonotonicClock, TickPacer
from hal.testing.peers import CAN_GROUP


def test_pacer_keeps_a_fixed_grid_and_counts_overruns(fake_clock) -> None:  # noqa: ANN001
    clock = fake_clock
    pacer = TickPacer(clock, sleep=clock.sleep)
    pacer.advance(0.05)
    t0 = clock.now()
    for i in range(6):
        if i == 2:
            clock.t += 0.02  # a slow tick within one period is absorbed by the grid
        pacer.advance(0.05)
    assert abs(clock.now() - t0 - 0.3) < 1e-9 and pacer.overruns == 0
    clock.t += 0.2  # far behind: re-anchor instead of bursting through missed ticks
    t1 = clock.now()
    pacer.advance(0.05)
    assert pacer.overruns == 1 and clock.now() == t1  # re-anchored: no sleep this tick
    pacer.advance(0.05)
    assert abs(clock.now() - t1 - 0.05) < 1e-9 and pacer.overruns == 1


def test_pacer_counts_ticks_reached_late(fake_clock) -> None:  # noqa: ANN001
    clock = fake_clock
    pacer = TickPacer(clock, sleep=clock.sleep)
    pacer.advance(0.05)
    clock.t += 0.03  # within the period: on time
    pacer.advance(0.05)
    clock.t += 0.07  # past its tick but less than a tick behind: missed, grid kept
    pacer.advance(0.05)
    timing = pacer.timing()
    assert pacer.missed == 1 and pacer.overruns == 0 and timing["missed"] == 1 and timing["ticks"] == 3
    assert timing["late_max_s"] == pytest.approx(0.02)
    later = pacer.timing(since=2)  # the last tick only
    assert later["ticks"] == 1 and later["missed"] == 1 and later["late_p50_s"] == pytest.approx(0.02)
    assert pacer.timing(since=3)["ticks"] == 0


def test_pacer_on_the_wall_clock_never_returns_before_its_tick() -> None:
    # no duration is asserted (the machine may be loaded): only that advance()
    # returns at or after the grid point it waited for, one period after the last
    clock = MonotonicClock()
    pacer = TickPacer(clock)
    pacer.advance(0.02)
    first = pacer.last_tick
    pacer.advance(0.02)
    assert clock.now() >= pacer.last_tick
    if pacer.overruns == 0:
        assert pacer.last_tick == pytest.approx(first + 0.02, abs=1e-12)


def test_echo_filter_drops_own_frames_only() -> None:
    port = random.randint(40000, 60000)
    a = open_can_bus("udp_multicast", CAN_GROUP, port=port)
    b = open_can_bus("udp_multicast", CAN_GROUP, port=port)
    raw = can.Bus(interface="udp_multicast", channel=CAN_GROUP, port=port, hop_limit=0)
    try:
        a.send(can.Message(arbitration_id=0x181, data=b"\x01\x02", is_extended_id=False))
        got_b = b.recv(1.0)
        assert got_b is not None and got_b.arbitration_id == 0x181  # others see it
        got_raw = raw.recv(1.0)
        while got_raw is not None and got_raw.arbitration_id != 0x181:
            got_raw = raw.recv(1.0)
        assert got_raw is not None  # the transport does loop frames back...
        assert a.recv(0.2) is None  # ...but the sender's filter drops its own
        b.send(can.Message(arbitration_id=0x201, data=b"\x03", is_extended_id=False))
        got_a = a.recv(1.0)
        assert got_a is not None and got_a.arbitration_id == 0x201
    finally:
        for bus in (a, b, raw):
            bus.shutdown()
