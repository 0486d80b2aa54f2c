"""HAL protocol figures: parser throughput and CANopen command latency.

    .venv/bin/python benchmarks/hal_protocols.py

Prints:
* DVL wrz / JSON line parsing and MIP deframing throughput (pure Python);
* CiA 402 planner steps per second;
* with the CiA 402 drive simulator in another process (udp_multicast,
  host-only): SDO set-up time per drive, and the latency from a new velocity
  reference to the drive reporting it back in TPDO1 (median and 95th
  percentile; includes the 10 ms service period and the 10 ms TPDO event timer).
"""

from __future__ import annotations

import random
import statistics
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from hal.drivers.ahrs_microstrain import MipParser, ahrs_packet  # noqa: E402
from hal.drivers.canbus import CanopenBus, open_can_bus  # noqa: E402
from hal.drivers.canopen_drive import Cia402Drive, DriveParams  # noqa: E402
from hal.drivers.cia402 import State, next_command  # noqa: E402
from hal.drivers.dvl_waterlinked import format_wrz, parse_json_line, parse_wrz_line  # noqa: E402
from hal.drivers.realtime import MonotonicClock  # noqa: E402
from hal.testing.peers import CAN_GROUP, ROOT, Peer  # noqa: E402


def rate(fn, n: int) -> float:  # noqa: ANN001
    t0 = time.perf_counter()
    for _ in range(n):
        fn()
    return n / (time.perf_counter() - t0)


def main() -> int:
    wrz = format_wrz(0.1, -0.2, 0.03, True, 2.5)
    js = '{"type": "velocity", "vx": 0.1, "vy": -0.2, "vz": 0.0, "fom": 0.01, "altitude": 4.2, "velocity_valid": true, "status": 0}'
    print(f"DVL wrz parse:          {rate(lambda: parse_wrz_line(wrz), 20000):10.0f} lines/s")
    print(f"DVL JSON parse:         {rate(lambda: parse_json_line(js), 20000):10.0f} lines/s")
    stream = b"".join(ahrs_packet((0.1, 0.2, 0.3), (0.0, 0.1, 0.2)) for _ in range(1000))
    t0 = time.perf_counter()
    n = len(MipParser().feed(stream))
    print(f"MIP deframe:            {n / (time.perf_counter() - t0):10.0f} packets/s")
    states = list(State)
    print(
        f"CiA 402 planner:        {rate(lambda: next_command(random.choice(states), State.OPERATION_ENABLED), 20000):10.0f} steps/s"
    )

    port = random.randint(40000, 60000)
    sim = Peer("hal.testing.cia402_sim", "--channel", CAN_GROUP, "--port", str(port), "--nodes", "1,2,3")
    clock = MonotonicClock()
    bus = CanopenBus(open_can_bus("udp_multicast", CAN_GROUP, port=port, hop_limit=0), clock.now)
    eds = str(ROOT / "hal" / "data" / "cia402_minimal.eds")
    try:
        drives = [
            Cia402Drive(bus.network, eds, DriveParams(n, 1000.0, 1000.0, 2.0), clock.now, f"j{n}") for n in (1, 2, 3)
        ]
        t0 = time.perf_counter()
        for d in drives:
            d.configure()
            bus.register(d)
        print(f"SDO set-up + NMT start: {(time.perf_counter() - t0) / len(drives) * 1000:10.1f} ms/drive")
        d = drives[0]
        d.request_enable()
        deadline = time.monotonic() + 3
        while d.reading().state != State.OPERATION_ENABLED and time.monotonic() < deadline:
            time.sleep(0.005)
        lat = []
        for i in range(30):
            v = 0.2 + 0.01 * (i % 2)  # small steps: the simulated acceleration ramp takes ~1 ms
            t0 = time.perf_counter()
            d.set_velocity(v)
            while abs(d.reading().velocity - v) > 1e-3 and time.perf_counter() - t0 < 1.0:
                time.sleep(0.0005)
            lat.append(time.perf_counter() - t0)
        lat.sort()
        print(
            f"velocity ref -> TPDO:   median {statistics.median(lat) * 1000:.1f} ms, p95 {lat[int(0.95 * len(lat)) - 1] * 1000:.1f} ms (n={len(lat)})"
        )
        for dr in drives:
            dr.request_safe_state()
        time.sleep(0.2)
    finally:
        bus.close()
        sim.stop()
    return 0


if __name__ == "__main__":
    sys.exit(main())
