"""The real vehicle: ArduSub for thrust commands, navigation put together from
ArduSub telemetry and the optional DVL and AHRS drivers.

Navigation sources, best first:

* attitude and angular rate: AHRS if configured, else ArduSub ATTITUDE;
* linear body velocity: DVL if configured, else ArduSub's EKF velocity
  (LOCAL_POSITION_NED, rotated into the vehicle frame; it contains the DVL when
  the DVL is forwarded to the autopilot). ``body_velocity`` is None when neither
  has ever arrived;
* position and depth: ArduSub LOCAL_POSITION_NED (depth from VFR_HUD otherwise);
* altitude: DVL, else the ArduSub rangefinder.

:meth:`ArdusubVehicle.health` is the worst of link, DVL and AHRS; a lost MAVLink
heartbeat or stale attitude is a FAULT.
"""

from __future__ import annotations

from typing import Callable

import numpy as np

from hal.drivers.ahrs_microstrain import MicrostrainAhrs
from hal.drivers.ardusub import ArdusubLink
from hal.drivers.dvl_waterlinked import WaterLinkedDvl, rpy_matrix
from hal.interfaces import Health, HealthState, NavigationState, Vehicle

_ORDER = [HealthState.OK, HealthState.DEGRADED, HealthState.FAULT, HealthState.MISSING]


class ArdusubVehicle(Vehicle):
    """Vehicle role on ArduSub (+ DVL, AHRS). ``params``: the validated ``ardusub`` config."""

    name = "vehicle"

    def __init__(self, params: dict, clock: Callable[[], float]) -> None:
        self._clock = clock
        self.actuated_dofs = tuple(params["actuated_dofs"])
        self.heartbeat_timeout = params["heartbeat_timeout"]
        self.telemetry_timeout = params["telemetry_timeout"]
        self.link = ArdusubLink(params["url"], clock, baudrate=params["baudrate"], source_system=params["source_system"],
                                target_system=params["target_system"], arm_mode=params["arm_mode"], command=params["command"],
                                max_speed=params["max_speed"], max_yaw_rate=params["max_yaw_rate"])
        self.dvl = WaterLinkedDvl(params["dvl"], clock, tuple(params["dvl"].get("mounting_rpy") or (0, 0, 0)),
                                  vehicle_max_speed=params["max_speed"],
                                  vehicle_max_acceleration=params.get("max_acceleration")) if params.get("dvl") else None
        self.ahrs = MicrostrainAhrs(params["ahrs"], clock, tuple(params["ahrs"].get("mounting_rpy") or (0, 0, 0))) if params.get("ahrs") else None

    # ------------------------------------------------------------------ life cycle

    def connect(self) -> None:
        self.link.connect()
        for sensor in (self.dvl, self.ahrs):
            if sensor is not None:
                sensor.connect()

    def disconnect(self) -> None:
        self.link.close()
        for sensor in (self.dvl, self.ahrs):
            if sensor is not None:
                sensor.close()

    open = connect
    close = disconnect

    # ------------------------------------------------------------------ commands

    def arm(self) -> None:
        self.link.arm(True)

    def disarm(self) -> None:
        self.link.set_velocity(np.zeros(6))
        self.link.arm(False)

    @property
    def armed(self) -> bool:
        return self.link.telemetry().armed

    def command_body_velocity(self, v: np.ndarray) -> None:
        v = np.asarray(v, dtype=float).reshape(6) * np.asarray(self.actuated_dofs, dtype=float)
        self.link.set_velocity(v)

    # ------------------------------------------------------------------ navigation

    def navigation(self) -> NavigationState:
        tel = self.link.telemetry()
        att, rates, t_att = tel.attitude, tel.rates, tel.attitude_t
        if self.ahrs is not None:
            a_rpy, a_rates, a_t = self.ahrs.attitude()
            if a_rpy is not None:
                att, t_att = a_rpy, a_t
                rates = a_rates if a_rates is not None else rates
        lin, t_lin = None, None
        if self.dvl is not None:
            lin, t_lin = self.dvl.velocity()
        elif tel.position_t is not None:
            lin, t_lin = rpy_matrix(tuple(att)).T @ tel.velocity_ned, tel.position_t
        body = None if lin is None else np.concatenate([lin, rates])
        vel_t = None if t_lin is None else (min(t_lin, t_att) if t_att is not None else t_lin)
        altitude = tel.altitude
        if self.dvl is not None:
            alt, alt_t = self.dvl.altitude()
            if alt is not None and alt_t is not None and self._clock() - alt_t < self.telemetry_timeout:
                altitude = alt
        return NavigationState(
            t=t_att if t_att is not None else float("nan"),
            position=tel.position,
            attitude=att,
            body_velocity=body,
            velocity_t=vel_t,
            depth=tel.depth if tel.depth is not None else float("nan"),
            altitude=altitude,
        )

    # ------------------------------------------------------------------ health

    def link_health(self) -> Health:
        now = self._clock()
        tel = self.link.telemetry()
        info = {"url": self.link.url, "mode": tel.mode, "armed": tel.armed,
                "heartbeat_age_s": None if tel.heartbeat_t is None else round(now - tel.heartbeat_t, 3),
                "rates_hz": tel.rates_hz}
        if tel.heartbeat_t is None:
            return Health(HealthState.MISSING, now, f"ArduSub: no heartbeat from system {self.link.target_system} on {self.link.url}", info)
        if now - tel.heartbeat_t > self.heartbeat_timeout:
            return Health(HealthState.FAULT, now, f"ArduSub: MAVLink heartbeat lost ({now - tel.heartbeat_t:.1f} s, limit {self.heartbeat_timeout:.1f} s)", info)
        if self.ahrs is None and (tel.attitude_t is None or now - tel.attitude_t > self.telemetry_timeout):
            return Health(HealthState.FAULT, now, "ArduSub: no fresh ATTITUDE telemetry", info)
        if tel.depth_t is None or now - tel.depth_t > self.telemetry_timeout:
            return Health(HealthState.FAULT, now, "ArduSub: no fresh depth (LOCAL_POSITION_NED / VFR_HUD)", info)
        return Health(HealthState.OK, now, "", info)

    def health(self) -> Health:
        parts = {"ardusub": self.link_health()}
        if self.dvl is not None:
            parts["dvl"] = self.dvl.health()
        if self.ahrs is not None:
            parts["ahrs"] = self.ahrs.health()
        worst = max((h.state for h in parts.values()), key=_ORDER.index)
        detail = "; ".join(h.detail for h in parts.values() if h.detail)
        info = {k: {"state": h.state.value, "detail": h.detail, **h.info} for k, h in parts.items()}
        return Health(worst, self._clock(), detail, info)
