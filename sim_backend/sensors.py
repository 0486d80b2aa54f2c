"""Navigation sensors: DVL, AHRS, depth, dead-reckoned position.

Each sensor samples the true state at its own rate and keeps the latest
measurement with the time it was *taken*. Noise comes from each sensor's own
random stream (see :mod:`sim_backend.rng`), drawn only when a sample is taken.

* DVL (e.g. Teledyne Explorer / Water Linked A50): body-frame linear velocity
  (m/s) and altitude (m) at ``dvl.rate_hz``; a ping is lost with
  ``dvl.dropout_probability``, during scheduled/injected dropouts, or when the
  altitude of its transducers (``dvl.mount_z_m`` below the reference point)
  is outside the bottom-lock band; the altitude it reports is the reference
  point's, as the navigation filter corrects it. ``dvl.present: false`` = no DVL.
* AHRS (Microstrain 3DM-GX3-35 class): roll/pitch/yaw with white noise and
  body rates [p q r] at ``ahrs.rate_hz`` with the gyro noise spectrum of
  :mod:`sim_backend.gyro` (white + bias + thruster vibration line). Rate noise
  is what makes an unfiltered compensating arm shake (MARIS), so keep it realistic.
* Depth (pressure) at the AHRS rate, white noise.
* Position: the vehicle's navigation filter output. With the full vehicle
  model, north and east are its dead reckoning (:attr:`FullVehicle.nav_xy`,
  passed to :meth:`Ahrs.update`): they drift as much as the velocity estimate
  is wrong, a lot without a DVL. With the first-order model: truth plus a
  random-walk drift (``navigation.position_drift_m_per_sqrt_s``).
"""

from __future__ import annotations

import math

import numpy as np

from . import sensor_kernel as sk
from .gyro import GyroNoise
from .rng import NormalBlock


def in_intervals(t: float, intervals: list[tuple[float, float]]) -> bool:
    """True if ``t`` (s) is inside any ``[t_start, t_end)`` interval."""
    for a, b in intervals:
        if a <= t < b:
            return True
    return False


class Dvl:
    """Latest DVL ping: ``velocity`` (3,) body frame, ``altitude`` (m), ``t`` (s)."""

    def __init__(self, params: dict, rng: np.random.Generator, velocity: np.ndarray | None = None):
        """``velocity``: a zeroed (3,) array to keep the ping's velocity in (e.g. a view into
        the backend's navigation buffer); default: a new one."""
        self.present = bool(params["dvl.present"])
        self.period = 1.0 / float(params["dvl.rate_hz"])
        self.noise = float(params["dvl.noise_std_mps"])
        self.p_drop = float(params["dvl.dropout_probability"])
        self.dropouts: list[tuple[float, float]] = list(params["dvl.dropouts"])
        self.alt_band = (float(params["dvl.min_altitude_m"]), float(params["dvl.max_altitude_m"]))
        self.mount_z = float(params["dvl.mount_z_m"])
        self._normals = NormalBlock(rng, 1024)
        self._uniform = rng  # same stream; draws are in a fixed order per ping
        self.next_t = 0.0
        self.t: float | None = None
        self.velocity = np.zeros(3) if velocity is None else velocity
        self.altitude: float | None = None

    def update(self, t: float, nu: np.ndarray, altitude: float) -> None:
        """Take a ping if one is due at time ``t`` (s); ``altitude``: the reference
        point's height above the floor (m)."""
        if not self.present or t + 1e-12 < self.next_t:
            return
        self.next_t += self.period
        if self.next_t <= t:  # large step: resynchronise instead of bursting
            self.next_t = t + self.period
        noise = self._normals.take(4)
        lost = self._uniform.random() < self.p_drop
        if (
            lost
            or in_intervals(t, self.dropouts)
            or not (self.alt_band[0] <= altitude - self.mount_z <= self.alt_band[1])
        ):
            return
        self.t = t
        self.velocity[:] = nu[:3] + self.noise * noise[:3]  # in place: the full vehicle reads it
        self.altitude = altitude + 0.5 * self.noise * noise[3]


class Ahrs:
    """Latest AHRS sample: ``attitude`` (3,) rad, ``rates`` (3,) rad/s, ``t`` (s);
    also samples depth (m) and the navigation position (3,) world."""

    def __init__(self, params: dict, rng: np.random.Generator, state: np.ndarray | None = None):
        """``state``: a zeroed (``N_A``,) array to keep the state in (e.g. a view into the
        backend's navigation buffer); default: a new one."""
        self.period = 1.0 / float(params["ahrs.rate_hz"])
        self.att_noise = (
            float(params["ahrs.attitude_noise_std_rad"]),
            float(params["ahrs.attitude_noise_std_rad"]),
            float(params["ahrs.yaw_noise_std_rad"]),
        )
        self.gyro = g = GyroNoise(params, rng)
        self.depth_noise = float(params["depth.noise_std_m"])
        self.drift_step = float(params["navigation.position_drift_m_per_sqrt_s"]) * math.sqrt(self.period)
        self._normals = NormalBlock(rng, 4096)
        self.next_t = 0.0
        self.t: float | None = None
        # one state array for the compiled sample (sim_backend.sensor_kernel); the
        # attributes are views into it, updated in place at each sample
        self._st = st = np.zeros(sk.N_A) if state is None else state
        st[sk.A_BIAS : sk.A_BIAS + 3] = g.bias
        st[sk.A_GYRO_T] = math.nan
        self.attitude = st[sk.A_ATT : sk.A_ATT + 3]
        self.rates = st[sk.A_RATES : sk.A_RATES + 3]
        self.position = st[sk.A_POS : sk.A_POS + 3]
        self.drift = st[sk.A_DRIFT : sk.A_DRIFT + 3]
        par = np.zeros(sk.N_P)
        par[sk.P_ATT_NOISE : sk.P_ATT_NOISE + 3] = self.att_noise
        par[sk.P_DEPTH_NOISE] = self.depth_noise
        par[sk.P_DRIFT_STEP] = self.drift_step
        par[sk.P_WHITE] = g.white
        par[sk.P_BIAS_STD] = g.bias_std
        par[sk.P_BIAS_TIME] = g.bias_time
        par[sk.P_VIB_W] = g.vib_w
        par[sk.P_VIB_AMP] = g.vib_amp
        par[sk.P_PHASE : sk.P_PHASE + 3] = g.phase
        self._par = par
        self._no_nav = np.zeros(2)
        self.nan_fault = False

    def update(
        self, t: float, eta: np.ndarray, nu: np.ndarray, vibration: float = 0.0, nav_xy: np.ndarray | None = None
    ) -> None:
        """Take a sample if one is due at ``t`` (s). ``vibration``: thruster activity
        (0..1) for the gyro's vibration line; ``nav_xy``: the navigation's own
        north/east estimate (m), None = truth plus random-walk drift."""
        if t + 1e-12 < self.next_t:
            return
        buf, i = self.begin_sample(t)
        if nav_xy is None:
            sk.ahrs_sample(t, eta, nu, vibration, self._no_nav, False, buf, i, self._st, self._par)
        else:
            sk.ahrs_sample(t, eta, nu, vibration, nav_xy, True, buf, i, self._st, self._par)
        self.end_sample()

    def begin_sample(self, t: float) -> tuple[np.ndarray, int]:
        """Book the sample of time ``t`` (s; it must be due) and reserve its 13 standard
        normals: ``(buffer, start)`` for :func:`sim_backend.sensor_kernel.ahrs_sample`,
        after which :meth:`end_sample` must be called (:meth:`update` does both; the
        coupled full vehicle's compiled step samples the AHRS itself)."""
        self.next_t += self.period
        if self.next_t <= t:
            self.next_t = t + self.period
        self.t = t
        return self._normals.reserve(13)

    @property
    def depth(self) -> float:
        """The last depth sample (m; 0 before the first)."""
        return float(self._st[sk.A_POS + 2])

    def end_sample(self) -> None:
        """After the compiled sample: the NaN fault (the coupled step calls it only with one)."""
        if self.nan_fault:
            self.attitude[:] = np.nan
            self.rates[:] = np.nan
