"""DVL reports the vehicle cannot produce are rejected (limits from the vehicle's
configured max speed and acceleration), and a DVL that keeps sending them is
lost like a silent one; against the DVL simulator over 127.0.0.1 TCP too."""

from __future__ import annotations

import json

import numpy as np
import pytest

from hal.drivers.dvl_waterlinked import ACCEL_ALLOWANCE, SPEED_ALLOWANCE, SPEED_MARGIN, WaterLinkedDvl
from hal.drivers.realtime import MonotonicClock
from hal.interfaces import HealthState
from hal.testing.peers import Peer, wait_until


class Clock:
    def __init__(self) -> None:
        self.t = 0.0

    def __call__(self) -> float:
        return self.t


def line(vx: float) -> str:
    return json.dumps({"type": "velocity", "vx": vx, "vy": 0.0, "vz": 0.0, "velocity_valid": True, "altitude": 2.0})


def test_speed_and_jumps_beyond_the_vehicle_limits_are_rejected() -> None:
    clock = Clock()
    dvl = WaterLinkedDvl(
        {"transport": "tcp", "timeout": 0.5}, clock, vehicle_max_speed=0.5, vehicle_max_acceleration=0.5
    )
    assert dvl.speed_limit == SPEED_MARGIN * 0.5 + SPEED_ALLOWANCE
    dvl.feed(line(0.3))
    assert np.allclose(dvl.velocity()[0], [0.3, 0, 0])
    clock.t = 0.1
    dvl.feed(line(9.0))  # the trial's 9 m/s: accepted by the fixed 10 m/s check, not by the vehicle's
    assert dvl.rejected["implausible"] == 1 and np.allclose(dvl.velocity()[0], [0.3, 0, 0])
    clock.t = 0.2
    dvl.feed(line(1.1))  # below the speed limit, but +0.8 m/s in 0.2 s: 4 m/s^2 for a 0.5 m/s^2 vehicle
    assert dvl.rejected["implausible"] == 2
    assert "implausible: velocity jumped 0.80 m/s" in dvl.health().detail
    clock.t = 0.3
    dvl.feed(line(0.3 + SPEED_MARGIN * 0.5 * 0.3 + ACCEL_ALLOWANCE - 0.01))  # just within what 0.3 s allow
    assert dvl.rejected["implausible"] == 2 and dvl.velocity()[1] == 0.3


@pytest.mark.peer
def test_a_dvl_sending_9_m_s_continuously_is_lost() -> None:
    sim = Peer("hal.testing.nav_sensor_sim", "dvl-tcp", "--rate", "20", "--velocity", "9.0,0.0,0.0")
    dvl = WaterLinkedDvl(
        {"transport": "tcp", "host": "127.0.0.1", "port": int(sim.ready), "timeout": 0.3},
        MonotonicClock().now,
        vehicle_max_speed=1.0,
        vehicle_max_acceleration=1.0,
    )
    dvl.connect()
    try:
        assert wait_until(lambda: dvl.rejected["implausible"] >= 5, 3.0), dvl.rejected
        h = dvl.health()
        assert dvl.velocity() == (None, None) and h.state == HealthState.FAULT
        assert "no velocity report received" in h.detail or "stale" in h.detail
        assert "implausible: speed 9.00 m/s above the vehicle's plausible 2.25 m/s" in h.detail
    finally:
        dvl.close()
        sim.stop()
