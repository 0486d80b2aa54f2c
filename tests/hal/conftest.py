"""Fixtures for the HAL tests: protocol peers in their own processes.

CAN runs over python-can udp_multicast on 239.74.163.2 with hop_limit 0 and a
random port, so nothing leaves the machine and parallel runs do not meet.
"""

from __future__ import annotations

import pytest

from hal.testing.peers import CAN_GROUP, Peer, free_udp_port


class FakeClock:
    """A clock whose time (s) moves only when someone sleeps (or a test sets ``t``):
    the pacer's arithmetic without real time."""

    def __init__(self) -> None:
        self.t = 0.0

    def now(self) -> float:
        return self.t

    def sleep(self, dt: float) -> None:
        assert dt > 0
        self.t += dt


@pytest.fixture
def fake_clock() -> FakeClock:
    return FakeClock()


@pytest.fixture
def can_port() -> int:
    return free_udp_port()


@pytest.fixture
def drive_sim(can_port):  # noqa: ANN001, ANN201
    """A CiA 402 simulator process with nodes 1-7 (arm) and 10-12 (gripper)."""
    peer = Peer(
        "hal.testing.cia402_sim", "--channel", CAN_GROUP, "--port", str(can_port), "--nodes", "1,2,3,4,5,6,7,10,11,12"
    )
    yield peer
    peer.stop()


@pytest.fixture
def drive_sim_with(can_port):  # noqa: ANN001, ANN201
    """Start CiA 402 simulator processes: ``drive_sim_with(nodes="1,2", eds=PATH)``."""
    peers: list[Peer] = []

    def start(nodes: str = "1,2,3", eds: str | None = None) -> Peer:
        args = ["--channel", CAN_GROUP, "--port", str(can_port), "--nodes", nodes]
        peer = Peer("hal.testing.cia402_sim", *args, *(["--eds", str(eds)] if eds else []))
        peers.append(peer)
        return peer

    yield start
    for p in peers:
        p.stop()
