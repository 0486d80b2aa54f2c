"""The real vehicle: ArduSub for motion, navigation put together from ArduSub
telemetry and the optional DVL and AHRS drivers.

Navigation sources, best first:

* attitude and angular rate: AHRS if configured, else ArduSub ATTITUDE;
* linear body velocity: DVL if configured, else ArduSub's EKF velocity
  (LOCAL_POSITION_NED velocity, rotated into the vehicle frame) while the EKF
  reports a velocity; ``body_velocity`` is None otherwise;
* position: ArduSub's EKF position (GLOBAL_POSITION_INT) in metres from a fixed
  world origin (the first EKF origin seen, logged; never HOME, which ArduSub
  moves at every arming), NaN ("unknown") while the EKF has none;
* depth: the depth sensor (SCALED_PRESSURE[n] and the autopilot's own
  ground-pressure and specific-gravity parameters), NaN until known;
* altitude: DVL, else the Ping echosounder (``ping``, a confident and fresh
  measurement), else ArduSub's downward rangefinder (DISTANCE_SENSOR facing
  down, e.g. a Ping wired to the autopilot, RNGFND1_TYPE 23).

:meth:`ArdusubVehicle.connect` refuses a set-up that cannot work (a serial
device that does not exist, a host name that does not resolve, a listening
address that is not this computer's) at once, naming the config field
(:mod:`hal.drivers.setup_checks`).

:meth:`ArdusubVehicle.arm` switches to ``arm_mode`` and arms, each step
confirmed by COMMAND_ACK and HEARTBEAT, and raises
:class:`hal.interfaces.EngageRefused` with ArduSub's reason otherwise; only then
do motion commands flow. :meth:`ArdusubVehicle.health` is the worst of link,
DVL and AHRS; its ``info`` carries the autopilot's own state (version, mode,
armed, EKF flags, unhealthy sensors, pre-arm messages, measured stream rates).
"""

from __future__ import annotations

import logging
from collections.abc import Callable

import numpy as np

from hal.config import site_of
from hal.drivers.ahrs_microstrain import MicrostrainAhrs
from hal.drivers.ardusub import MANUAL_MODES, ArdusubLink
from hal.drivers.ardusub_state import EKF_FLAGS, Telemetry, flag_names
from hal.drivers.dvl_waterlinked import WaterLinkedDvl, rpy_matrix
from hal.drivers.ping_altimeter import PingAltimeter
from hal.drivers.setup_checks import check_mavlink_url, check_stream_source
from hal.interfaces import EngageRefused, Health, HealthState, NavigationState, Vehicle


def _finite(a: np.ndarray) -> bool:
    """All of a small float array finite (one numpy call instead of two)."""
    return bool(np.isfinite(a).all())


_ORDER = [HealthState.OK, HealthState.DEGRADED, HealthState.FAULT, HealthState.MISSING]
#: Messages whose measured rate `maris hal check` shows.
SHOWN_RATES = (
    "HEARTBEAT",
    "ATTITUDE",
    "GLOBAL_POSITION_INT",
    "LOCAL_POSITION_NED",
    "SCALED_PRESSURE",
    "SCALED_PRESSURE2",
    "SYS_STATUS",
    "EKF_STATUS_REPORT",
    "DISTANCE_SENSOR",
)


def _lat_lon(point: tuple[float, float]) -> str:
    """``lat, lon`` in degrees, to 1e-7 degree (about a centimetre)."""
    lat, lon = point
    return f"{lat:.7f}, {lon:.7f}"


class ArdusubVehicle(Vehicle):
    """Vehicle role on ArduSub (+ DVL, AHRS). ``params``: the validated ``ardusub`` config."""

    name = "vehicle"

    def __init__(self, params: dict, clock: Callable[[], float]) -> None:
        self._clock = clock
        self.actuated_dofs = tuple(params["actuated_dofs"])
        self._actuated = [float(a) for a in self.actuated_dofs]
        self.heartbeat_timeout = params["heartbeat_timeout"]
        self.telemetry_timeout = params["telemetry_timeout"]
        self.arm_timeout = params.get("arm_timeout", 5.0)
        fs = params.get("manual_full_stick")
        full_stick = None if not fs else (fs["surge_mps"], fs["sway_mps"], fs["heave_mps"], fs["yaw_rad_s"])
        self.link = ArdusubLink(
            params["url"],
            clock,
            baudrate=params["baudrate"],
            source_system=params["source_system"],
            target_system=params["target_system"],
            arm_mode=params["arm_mode"],
            command=params["command"],
            max_speed=params["max_speed"],
            max_yaw_rate=params["max_yaw_rate"],
            depth_sensor=params.get("depth_sensor", 0),
            full_stick=full_stick,
            heartbeat_timeout=params["heartbeat_timeout"],
        )
        self.dvl = (
            WaterLinkedDvl(
                params["dvl"],
                clock,
                tuple(params["dvl"].get("mounting_rpy") or (0, 0, 0)),
                vehicle_max_speed=params["max_speed"],
                vehicle_max_acceleration=params.get("max_acceleration"),
            )
            if params.get("dvl")
            else None
        )
        self.ahrs = (
            MicrostrainAhrs(params["ahrs"], clock, tuple(params["ahrs"].get("mounting_rpy") or (0, 0, 0)))
            if params.get("ahrs")
            else None
        )
        self.ping = PingAltimeter(params["ping"], clock, where=site_of(params, "ping")) if params.get("ping") else None
        self._params = params
        self._want_armed = False

    # ------------------------------------------------------------------ life cycle
    def check_setup(self) -> None:
        """Set-up errors that no retry mends, now (SetupError naming the config field)."""
        p = self._params
        check_mavlink_url(p["url"], site_of(p, "url"), "ArduSub MAVLink link")
        for name, what in (("dvl", "DVL"), ("ahrs", "AHRS")):
            if p.get(name):
                check_stream_source(p[name], site_of(p, name), what)
        if self.ping is not None:
            self.ping.check_setup()

    def connect(self) -> None:
        self.check_setup()
        self.link.connect()
        for sensor in (self.dvl, self.ahrs, self.ping):
            if sensor is not None:
                sensor.connect()

    def disconnect(self) -> None:
        self.link.close()
        for sensor in (self.dvl, self.ahrs, self.ping):
            if sensor is not None:
                sensor.close()

    open = connect
    close = disconnect

    # ------------------------------------------------------------------ commands
    def arm(self) -> None:
        """Switch to ``arm_mode`` and arm, both confirmed; raise EngageRefused with the reason otherwise."""
        link = self.link
        tel = link.telemetry()
        now = self._clock()
        if tel.heartbeat_t is None or now - tel.heartbeat_t > self.heartbeat_timeout:
            raise EngageRefused(f"ArduSub on {link.url}: no heartbeat, cannot arm ({link.link_error or 'silent'})")
        why = link.set_mode(link.arm_mode, timeout=self.arm_timeout)
        if why is not None:
            hint = ""
            if link.arm_mode == "GUIDED" and not link.state.has_position():
                flags = ", ".join(flag_names(link.state.ekf_flags or 0, EKF_FLAGS)) or "none"
                hint = (
                    f" [GUIDED needs a position estimate and the EKF has none (EKF flags: {flags}); forward a DVL"
                    " or GPS to ArduSub, or use the open-loop fallback `command: manual_control`]"
                )
            raise EngageRefused(why + hint)
        self._want_armed = True
        why = link.set_armed(True, timeout=self.arm_timeout)
        if why is not None:
            self._want_armed = False
            raise EngageRefused(why)
        link.engage()

    def disarm(self) -> None:
        """Stop motion commands and disarm (confirmed; a refusal is only logged, never raised)."""
        self._want_armed = False
        self.link.disengage()
        if self.link.telemetry().armed:
            why = self.link.set_armed(False, timeout=2.0)
            if why is not None:
                logging.getLogger(__name__).warning("ArduSub disarm: %s", why)

    @property
    def armed(self) -> bool:
        return self.link.telemetry().armed

    def command_body_velocity(self, v: np.ndarray) -> None:
        vals = np.asarray(v, dtype=float).reshape(6).tolist()  # plain floats: cheaper than numpy on 6 values
        self.link.set_velocity_values([x * a for x, a in zip(vals, self._actuated)])

    # ------------------------------------------------------------------ navigation
    def navigation(self) -> NavigationState:
        """The navigation solution from the sources' latest readings (every control step:
        lean; the readings are copies, the sources go on updating theirs)."""
        tel = self.link.nav_fields()
        att, rates, t_att = tel.attitude, tel.rates, tel.attitude_t
        if self.ahrs is not None:
            a_rpy, a_rates, a_t = self.ahrs.attitude()
            if a_rpy is not None:
                att, t_att = a_rpy, a_t
                rates = a_rates if a_rates is not None else rates
        lin, t_lin = None, None
        if self.dvl is not None:
            lin, t_lin = self.dvl.velocity()
        elif tel.velocity_ned is not None and _finite(att):
            lin, t_lin = rpy_matrix(tuple(att)).T @ tel.velocity_ned, tel.velocity_t
        body = None if lin is None or not _finite(rates) else np.concatenate((lin, rates))
        vel_t = None if body is None else (t_lin if t_att is None or t_lin is None else min(t_lin, t_att))
        altitude = tel.altitude
        for source, limit in ((self.ping, self.ping.timeout if self.ping else 0.0), (self.dvl, self.telemetry_timeout)):
            if source is not None:  # the later source wins: the DVL over the Ping over ArduSub's rangefinder
                alt, alt_t = source.altitude()
                if alt is not None and alt_t is not None and self._clock() - alt_t < limit:
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
    def _info(self, tel: Telemetry, now: float) -> dict:
        link = self.link
        prearm = [t for (_tt, _s, t) in tel.statustexts if t.startswith(("PreArm", "Arm"))][-4:]
        recent = [t for (_tt, _s, t) in tel.statustexts][-4:]
        return {
            "url": link.url,
            "link": link.link_state,
            "version": tel.version or "unknown",
            "mode": tel.mode,
            "armed": tel.armed,
            "heartbeat_age_s": None if tel.heartbeat_t is None else round(now - tel.heartbeat_t, 3),
            "command": link.command,
            "yaw_path": link.yaw_path if link.command == "setpoint" else "manual sticks",
            "ekf_flags": flag_names(tel.ekf_flags, EKF_FLAGS) if tel.ekf_flags is not None else "not reported",
            "position": "unknown" if not np.isfinite(tel.position[0]) else [round(float(x), 2) for x in tel.position],
            "world_origin": None if tel.anchor is None else f"{_lat_lon(tel.anchor)} ({tel.anchor_source})",
            "depth_m": None if tel.depth is None else round(tel.depth, 3),
            "depth_source": tel.depth_source,
            "unhealthy_sensors": tel.unhealthy_sensors or "none",
            "prearm_messages": prearm or "none",
            "recent_messages": recent or "none",
            "rates_hz": {k: tel.rates_hz.get(k, 0.0) for k in SHOWN_RATES},
        }

    def link_health(self) -> Health:
        now = self._clock()
        link = self.link
        tel = link.telemetry()
        info = self._info(tel, now)
        where = f"ArduSub on {link.url}"
        if tel.heartbeat_t is None:
            why = link.link_error or f"no HEARTBEAT from system {link.target_system}"
            return Health(HealthState.MISSING, now, f"{where}: not connected ({why})", info)
        if now - tel.heartbeat_t > self.heartbeat_timeout:
            extra = f"; {link.link_error}" if link.link_state == "retrying" else ""
            return Health(
                HealthState.FAULT,
                now,
                f"{where}: heartbeat lost ({now - tel.heartbeat_t:.1f} s, limit {self.heartbeat_timeout:.1f} s){extra}",
                info,
            )
        asked = link.streams_requested_s()
        if asked is None or asked < 1.2:
            what = "not requested yet" if asked is None else f"requested {asked:.1f} s ago"
            return Health(HealthState.FAULT, now, f"{where}: waiting for the telemetry streams ({what})", info)
        if self._want_armed and link.engaged:
            last = f' (last message: "{tel.statustexts[-1].text}")' if tel.statustexts else ""
            if not tel.armed:
                return Health(HealthState.FAULT, now, f"{where}: the autopilot disarmed{last}", info)
            if tel.mode != link.arm_mode:
                return Health(
                    HealthState.FAULT, now, f"{where}: the autopilot left {link.arm_mode}, now {tel.mode}{last}", info
                )
        if self.ahrs is None and (tel.attitude_t is None or now - tel.attitude_t > self.telemetry_timeout):
            return Health(
                HealthState.FAULT,
                now,
                f"{where}: no fresh ATTITUDE (streams requested; rates {info['rates_hz']})",
                info,
            )
        if tel.depth_t is None or now - tel.depth_t > self.telemetry_timeout:
            why = "no depth-sensor pressure" if tel.depth_source is None else f"depth unknown from {tel.depth_source}"
            return Health(HealthState.FAULT, now, f"{where}: {why}", info)
        if not np.isfinite(tel.position[0]) or tel.position_t is None or now - tel.position_t > self.telemetry_timeout:
            flags = ", ".join(flag_names(tel.ekf_flags or 0, EKF_FLAGS)) or "none"
            state = HealthState.DEGRADED if link.command == "manual_control" else HealthState.FAULT
            return Health(state, now, f"{where}: position unknown (EKF flags: {flags})", info)
        if tel.unhealthy_sensors:
            return Health(
                HealthState.DEGRADED, now, f"{where}: unhealthy sensors: {', '.join(tel.unhealthy_sensors)}", info
            )
        return Health(HealthState.OK, now, "", info)

    def health(self) -> Health:
        parts = {"ardusub": self.link_health()}
        if self.dvl is not None:
            parts["dvl"] = self.dvl.health()
        if self.ahrs is not None:
            parts["ahrs"] = self.ahrs.health()
        if self.ping is not None:
            parts["ping"] = self.ping.health()
        worst = max((h.state for h in parts.values()), key=_ORDER.index)
        detail = "; ".join(h.detail for h in parts.values() if h.detail)
        info = {k: {"state": h.state.value, "detail": h.detail, **h.info} for k, h in parts.items()}
        return Health(worst, self._clock(), detail, info)


__all__ = ["ArdusubVehicle", "MANUAL_MODES"]
