"""A mixed HAL config whose simulated vehicle follows the real one (``sim.follow_vehicle``):
the ArduSub peer (another process, 127.0.0.1 TCP) as the vehicle, the simulator for the
rest; the simulated vehicle is where the real one's navigation says, so the simulated
detector sees the scenario from there."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from hal.config import load_hal_config
from hal.factory import build_backend
from hal.testing.peers import Peer, free_tcp_port, wait_until

pytestmark = pytest.mark.peer


def test_the_simulated_vehicle_follows_the_real_ones_navigation(tmp_path: Path) -> None:
    pytest.importorskip("sim_backend")
    port = free_tcp_port()
    peer = Peer("hal.testing.ardusub_peer", "--url", f"tcpin:127.0.0.1:{port}", "--position", "gps")
    (tmp_path / "hal.yaml").write_text(f"""\
devices:
  vehicle: {{driver: ardusub, url: "tcp:127.0.0.1:{port}"}}
  arm: {{driver: sim}}
  gripper: {{driver: sim}}
  detector: {{driver: sim}}
sim: {{scenario: bluerov2_pool, follow_vehicle: true}}
""")
    backend = build_backend(load_hal_config(tmp_path / "hal.yaml"))
    try:
        backend.open()
        vehicle = backend.devices.vehicle
        assert wait_until(lambda: np.all(np.isfinite(vehicle.navigation().position)), 10.0)
        backend.advance(0.05)
        nav = vehicle.navigation()
        sim_eta = np.asarray(backend.sim.vehicle.eta)  # type: ignore[attr-defined]
        real = np.concatenate([nav.position[:2], [nav.depth], nav.attitude])
        assert np.allclose(sim_eta, real, atol=0.05), (sim_eta, real)  # within one tick of motion
    finally:
        backend.close()
        peer.stop()
