"""Blue Robotics Ping echosounder (Ping1D) as the vehicle's altimeter.

At ``ping.rate_hz`` the sonar gives the distance to the pool floor along its
beam: the transducer looks down, ``ping.mount_z_m`` below the reference point;
over a flat floor the nearest echo inside the beam (full width
``ping.beam_rad``) is the vertical one while the tilt of the vehicle is less
than half the beam, and the one at the beam's edge beyond that
(``h / cos(tilt - beam / 2)``). The sonar's tracking algorithm low-passes the
target distance (``ping.filter_time_s``); each reading carries white noise
(``ping.noise_std_m``). A reading is lost (low confidence, which the driver
discards) with ``ping.low_confidence_probability`` and whenever the distance is
outside ``[ping.min_range_m, ping.max_range_m]``.

The altitude it reports is the reference point's, as the HAL driver's
``offset_m`` makes it (:mod:`hal.drivers.ping_altimeter`): the distance plus
the transducer's depth below the reference point. Echoes from the small pipe under the beam are neglected (the
sonar locks on the strongest return, the floor's).
"""

from __future__ import annotations

import math

import numpy as np

from .rng import NormalBlock


class PingAltimeter:
    """Latest Ping reading: ``altitude`` (m, reference point above the floor) taken at ``t`` (s)."""

    def __init__(self, params: dict, rng: np.random.Generator):
        self.present = bool(params["ping.present"])
        self.period = 1.0 / float(params["ping.rate_hz"])
        self.noise = float(params["ping.noise_std_m"])
        self.half_beam = 0.5 * float(params["ping.beam_rad"])
        self.range = (float(params["ping.min_range_m"]), float(params["ping.max_range_m"]))
        self.mount_z = float(params["ping.mount_z_m"])
        self.p_low = float(params["ping.low_confidence_probability"])
        self.filter_time = float(params["ping.filter_time_s"])
        self.timeout = float(params["ping.timeout_s"])
        self._normals = NormalBlock(rng, 256)
        self._uniform = rng
        self.next_t = 0.0
        self.t: float | None = None
        self.altitude: float | None = None
        self._tracked: float | None = None  # the sonar's filtered target distance (m)
        self._tracked_t = 0.0

    def distance(self, eta: np.ndarray, floor_depth: float) -> float:
        """True distance (m) from the transducer to the floor along the nearest beam ray."""
        roll, pitch = float(eta[3]), float(eta[4])
        cos_tilt = math.cos(roll) * math.cos(pitch)  # the beam axis (body z) against the vertical
        tilt = math.acos(max(-1.0, min(1.0, cos_tilt)))
        depth = float(eta[2]) + self.mount_z * cos_tilt  # the transducer's depth
        h = floor_depth - depth
        if tilt <= self.half_beam:
            return h
        return h / max(1e-6, math.cos(tilt - self.half_beam))

    def update(self, t: float, eta: np.ndarray, floor_depth: float) -> None:
        """Take a reading if one is due at ``t`` (s)."""
        if not self.present or t + 1e-12 < self.next_t:
            return
        self.next_t += self.period
        if self.next_t <= t:
            self.next_t = t + self.period
        d = self.distance(eta, floor_depth)
        n = float(self._normals.take(1)[0])
        low = self._uniform.random() < self.p_low
        if self._tracked is None or self.filter_time <= 0.0:
            self._tracked = d
        else:
            a = 1.0 - math.exp(-(t - self._tracked_t) / self.filter_time)
            self._tracked += a * (d - self._tracked)
        self._tracked_t = t
        if low or not (self.range[0] <= d <= self.range[1]):
            return
        self.t = t
        self.altitude = self._tracked + self.noise * n + self.mount_z  # the reference point is mount_z above it

    def fresh_altitude(self, now: float) -> float | None:
        """The last altitude if it is younger than ``ping.timeout_s``, else None."""
        if self.t is None or now - self.t > self.timeout:
            return None
        return self.altitude
