"""A Reach Robotics arm (Alpha 5, Bravo 7) on the Reach serial protocol, as the
:class:`hal.interfaces.Arm` (driver ``reach_arm``; the jaw is
:class:`hal.drivers.reach_jaw.ReachJaw` on the same link).

* **Feedback**: each joint streams POSITION, VELOCITY and CURRENT as its
  heartbeat at ``feedback_rate_hz`` (set up at connect); MODE and the hardware
  status flags are asked for every ``status_period`` s. A joint whose readings
  are older than ``stale_timeout`` s faults the arm (killed or stalled arm,
  broken cable): health FAULT, the joints are sent zero velocity and STANDBY.
* **Commands**: one VELOCITY packet per joint per :meth:`command_joint_velocity`
  call (every KCL arm step), clipped to the joint's ``max_velocity`` and to the
  device's own velocity limit, all in one write; nothing is sent while the arm
  is not enabled or faulted.
* **Modes**: :meth:`ReachArm.enable` puts every joint in VELOCITY mode (zero
  demand) and :meth:`ReachArm.disable` in STANDBY (after a zero demand), each
  confirmed by reading the mode back (``EngageRefused`` / a fault otherwise). A
  joint that leaves VELOCITY mode while enabled, or reports hardware status
  flags, faults the arm; faults stay until the next :meth:`enable` finds their
  cause gone (:meth:`reset_faults` clears them without enabling).
* **Limits**: at connect every joint is asked for its position, velocity and
  current limits; with ``urdf`` the model's joint ranges must lie within the
  device's position limits and its velocity limits must not exceed the
  device's, else the arm reports FAULT (the KCL would command motions the arm
  refuses).
* **No timeout on a velocity demand** in the protocol: an arm whose host dies
  keeps its last velocity. Zero velocity and STANDBY go out on every exit path
  this process has (:meth:`disconnect`, :meth:`safe_stop`, faults, atexit,
  SIGTERM/SIGHUP) and from the guardian process when this one dies or stalls
  (:mod:`hal.drivers.reach_link`, docs/faults.md).
"""

from __future__ import annotations

import math
import threading
import xml.etree.ElementTree as ET
from collections.abc import Callable
from typing import Any

import numpy as np

from hal.config import site_of
from hal.drivers.reach_device import ReachDevice
from hal.drivers.reach_link import LinkSpec, ReachLink
from hal.drivers.reach_protocol import Mode, PacketId, mode_name
from hal.interfaces import Arm, EngageRefused, Health, HealthState, JointState


def link_spec(params: dict[str, Any], where: str) -> LinkSpec:
    """The link settings of a validated ``reach_arm`` / ``reach_jaw`` config."""
    return LinkSpec(
        transport=params["transport"],
        device=params.get("device"),
        baudrate=params.get("baudrate", 115200),
        host=params.get("host") or "",
        port=params.get("port", 6789),
        local_port=params.get("local_port", 0),
        where=where,
        guardian=params.get("guardian", True),
        guard_timeout=params.get("guard_timeout", 0.5),
    )


def urdf_limits(path: str) -> dict[str, tuple[float, float, float]]:
    """Joint name -> (lower, upper, velocity) of the limited joints of a URDF file."""
    out: dict[str, tuple[float, float, float]] = {}
    for joint in ET.parse(path).getroot().iter("joint"):
        lim = joint.find("limit")
        if joint.get("type") in ("revolute", "prismatic") and lim is not None:
            out[str(joint.get("name"))] = (
                float(lim.get("lower", "nan")),
                float(lim.get("upper", "nan")),
                float(lim.get("velocity", "nan")),
            )
    return out


class ReachArm(Arm):
    """Joints of a Reach arm. ``params``: the validated ``reach_arm`` config."""

    name = "arm"

    def __init__(self, params: dict[str, Any], clock: Callable[[], float]) -> None:
        self._clock = clock
        self._where = site_of(params)
        self.link = ReachLink.shared(link_spec(params, site_of(params, "transport")), clock)
        joints = params["joints"]
        self.joint_names = tuple(j["name"] for j in joints)
        self.devices = [ReachDevice(self.link, j["device_id"], j["name"]) for j in joints]
        self._max_velocity = [float(j["max_velocity"]) for j in joints]
        self._offset = [float(j.get("offset", 0.0)) for j in joints]
        self._sign = [float(j.get("sign", 1.0)) for j in joints]
        self.feedback_rate_hz = int(params["feedback_rate_hz"])
        self.status_period = float(params["status_period"])
        self.stale_timeout = float(params["stale_timeout"])
        self.mode_timeout = float(params["mode_timeout"])
        self._urdf = params.get("urdf")
        self._urdf_where = site_of(params, "urdf")
        self._tolerance = float(params.get("limit_tolerance", 0.01))
        self._lock = threading.Lock()
        self._enabled = False
        self._fault: str | None = None  # latched until enable()/reset_faults() finds the cause gone
        self._limit_problems: list[str] = []
        self._connected = False
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None
        self._commands = 0

    # ------------------------------------------------------------------ life cycle
    def connect(self) -> None:
        """Open the link (set-up errors raise at once), set up each joint's heartbeat,
        ask for limits and status, leave every joint in STANDBY."""
        for d in self.devices:
            self.link.register(d.device_id, d.on_packet)
        try:
            self.link.acquire()
        except Exception:
            for d in self.devices:
                self.link.unregister(d.device_id)
            raise
        self._connected = True
        self.link.post(b"".join(d.velocity_frame(0.0) + d.mode_frame(Mode.STANDBY) for d in self.devices))
        self.link.post(b"".join(d.heartbeat_setup(self.feedback_rate_hz) for d in self.devices))
        self.link.post(b"".join(d.request_limits() + d.request_status() for d in self.devices))
        self._stop.clear()
        self._thread = threading.Thread(target=self._service, name="reach-arm", daemon=True)
        self._thread.start()

    def disconnect(self) -> None:
        """Zero velocity and STANDBY (confirmed, bounded), then release the link. Idempotent."""
        if not self._connected:
            return
        self._stop.set()
        if self._thread is not None:
            self._thread.join(timeout=2.0)
            self._thread = None
        self._to_standby(confirm=True)
        for d in self.devices:
            self.link.unregister(d.device_id)
        self.link.release()
        self._connected = False

    # ------------------------------------------------------------------ service thread
    def _service(self) -> None:
        """Status requests, limit requests until answered, the stale-reading watchdog."""
        next_status = 0.0
        while not self._stop.wait(0.02):
            now = self._clock()
            if now >= next_status:
                next_status = now + self.status_period
                frames = b"".join(d.request_status() for d in self.devices)
                frames += b"".join(d.request_limits() for d in self.devices if len(d.state.limits) < 3)
                self.link.post(frames)
                self._check_limits()
            if self._enabled:
                why = self._problem(now)
                if why:
                    self._trip(why)

    def _trip(self, why: str) -> None:
        """A fault while enabled: latch it and stop every joint (zero velocity, STANDBY)."""
        with self._lock:
            if self._fault is None:
                self._fault = why
            self._enabled = False
        self._to_standby(confirm=False)

    def _to_standby(self, confirm: bool) -> None:
        self.link.set_armed(False)
        frames = b"".join(d.velocity_frame(0.0) for d in self.devices)
        self.link.post(frames + b"".join(d.mode_frame(Mode.STANDBY) for d in self.devices))
        if confirm:
            for d in self.devices:
                d.wait_mode(Mode.STANDBY, self.mode_timeout)

    # ------------------------------------------------------------------ problems
    def _joint_problem(self, d: ReachDevice, now: float) -> str | None:
        s = d.state
        where = f"arm joint {d.name} (device 0x{d.device_id:02X})"
        if s.position_t is None:
            return f"{where}: no reading received ({self._link_text()})"
        age = now - min(t if t is not None else -math.inf for t in (s.position_t, s.velocity_t, s.current_t))
        if age > self.stale_timeout:
            return f"{where}: stale readings ({age:.3f} s old, limit {self.stale_timeout:.3f} s; {self._link_text()})"
        if s.flags:
            return f"{where}: hardware status flags 0x{s.flags:08X} (bits {', '.join(str(b) for b in range(32) if s.flags >> b & 1)})"
        if self._enabled and s.mode is not None and s.mode != Mode.VELOCITY:
            return f"{where}: left VELOCITY mode, now {mode_name(s.mode)}"
        return None

    def _link_text(self) -> str:
        link = self.link
        return f"link {link.link_state}" + (f": {link.link_error}" if link.link_error else "")

    def _problem(self, now: float) -> str | None:
        note = self.link.guardian_note
        if note:
            return f"the guardian stopped the arm: {note}"
        for d in self.devices:
            why = self._joint_problem(d, now)
            if why:
                return why
        return None

    def _check_limits(self) -> None:
        """Device limits against the URDF (once every joint answered)."""
        if not self._urdf or any(len(d.state.limits) < 3 for d in self.devices):
            return
        try:
            model = urdf_limits(self._urdf)
        except (OSError, ET.ParseError) as exc:
            self._limit_problems = [f"{self._urdf_where}: cannot read {self._urdf}: {exc}"]
            return
        problems = []
        tol = self._tolerance
        for d, off, sign in zip(self.devices, self._offset, self._sign):
            if d.name not in model:
                problems.append(f"joint {d.name} is not a limited joint of {self._urdf}")
                continue
            lo, hi, vel = model[d.name]
            dlo, dhi = d.state.limits[PacketId.POSITION_LIMITS]
            a, b = sorted((sign * dlo + off, sign * dhi + off))
            if lo < a - tol or hi > b + tol:
                problems.append(
                    f"joint {d.name}: the URDF's range {lo:.3f}..{hi:.3f} rad exceeds the device's position "
                    f"limits {a:.3f}..{b:.3f} rad"
                )
            vlo, vhi = d.state.limits[PacketId.VELOCITY_LIMITS]
            dev_v = min(abs(vlo), abs(vhi))
            if vel > dev_v + tol:
                problems.append(
                    f"joint {d.name}: the URDF's velocity limit {vel:.3f} rad/s exceeds the device's {dev_v:.3f} rad/s"
                )
        self._limit_problems = problems

    # ------------------------------------------------------------------ Arm interface
    def reset_faults(self) -> list[str]:
        """Clear a latched fault whose cause is gone (joints stay in STANDBY); what it was."""
        with self._lock:
            was, self._fault = self._fault, None
        return [f"{self._where}: {was}"] if was else []

    def enable(self) -> None:
        """VELOCITY mode (zero demand) on every joint, confirmed; EngageRefused otherwise."""
        now = self._clock()
        why = self._problem(now) or ("; ".join(self._limit_problems) or None)
        if why:
            raise EngageRefused(f"Reach arm: cannot enable: {why}")
        with self._lock:
            self._fault = None
        self.link.post(b"".join(d.velocity_frame(0.0) + d.mode_frame(Mode.VELOCITY) for d in self.devices))
        refused = []
        for d in self.devices:
            mode = d.wait_mode(Mode.VELOCITY, self.mode_timeout)
            if mode != Mode.VELOCITY:
                refused.append(f"{d.name} reads {'no mode' if mode is None else mode_name(mode)}")
        if refused:
            self._to_standby(confirm=False)
            raise EngageRefused(
                f"Reach arm: VELOCITY mode not confirmed within {self.mode_timeout:g} s: {', '.join(refused)}"
            )
        with self._lock:
            self._enabled = True
        self.link.set_armed(True)

    def disable(self) -> None:
        with self._lock:
            self._enabled = False
        self._to_standby(confirm=True)

    def safe_stop(self) -> None:
        """Zero velocity and STANDBY now (queued; never raises, never waits)."""
        try:
            with self._lock:
                self._enabled = False
            self._to_standby(confirm=False)
        except Exception:  # noqa: BLE001 - must not raise
            pass

    def command_joint_velocity(self, qdot: np.ndarray) -> None:
        values = np.asarray(qdot, dtype=float).reshape(-1).tolist()
        if len(values) != len(self.devices):
            raise ValueError(f"arm: expected {len(self.devices)} joint velocities, got {len(values)}")
        if not all(map(math.isfinite, values)):
            self.safe_stop()
            return
        if not self._enabled:
            return  # disabled or faulted: references are ignored until enable()
        frames = []
        for d, v, vmax, sign in zip(self.devices, values, self._max_velocity, self._sign):
            lim = d.state.limits.get(PacketId.VELOCITY_LIMITS)
            bound = min(vmax, abs(lim[0]), abs(lim[1])) if lim else vmax
            frames.append(d.velocity_frame(sign * max(-bound, min(bound, v))))
        self.link.post(b"".join(frames))
        self._commands += 1

    def joint_state(self) -> JointState:
        now = self._clock()
        pos, vel, cur, times, faults = [], [], [], [], []
        for d, off, sign in zip(self.devices, self._offset, self._sign):
            s = d.state
            pos.append(sign * s.position + off)
            vel.append(sign * s.velocity)
            cur.append(sign * s.current_ma / 1000.0)
            times.append(s.position_t)
        why = self._fault or self._problem(now) if (self._enabled or self._fault) else None
        if why:
            faults.append(why)
        known = [t for t in times if t is not None]
        t = min(known) if known and len(known) == len(times) else float("nan")
        return JointState(
            t=t,
            position=np.array(pos, dtype=float),
            velocity=np.array(vel, dtype=float),
            current=np.array(cur, dtype=float),
            fault="; ".join(faults) or None,
        )

    def health(self) -> Health:
        now = self._clock()
        parts = []
        for d in self.devices:
            s = d.snapshot()
            problem = self._joint_problem(d, now)
            state = HealthState.MISSING if s.position_t is None else HealthState.FAULT if problem else HealthState.OK
            parts.append(
                {
                    "name": d.name,
                    "state": state.value,
                    "detail": problem or "",
                    "device_id": f"0x{d.device_id:02X}",
                    "mode": d.describe_mode(),
                    "age_s": None if s.position_t is None else round(now - s.position_t, 3),
                    "status_flags": None if s.flags is None else f"0x{s.flags:08X}",
                    "limits": {
                        PacketId(k).name.lower(): [round(v, 4) for v in lim] for k, lim in sorted(s.limits.items())
                    },
                }
            )
        info: dict[str, Any] = {"parts": parts, **self.link.info(now), "feedback_rate_hz": self.feedback_rate_hz}
        if info.get("rx_packets_per_s") is None:
            info["starting"] = True  # `maris hal check` waits for the link's first second of rates
        notes = []
        if not self._urdf:
            notes.append("no `urdf` given: the device's limits are not checked against the model")
        elif any(len(d.state.limits) < 3 for d in self.devices):
            notes.append("device limits not all received yet")
        if notes:
            info["notes"] = notes
        problems = [p for p in (self._fault, self._problem(now)) if p] + self._limit_problems
        if any(p["state"] == HealthState.MISSING.value for p in parts) and not self._fault:
            return Health(HealthState.MISSING, now, problems[0] if problems else "Reach arm: not heard from", info)
        if problems:
            return Health(HealthState.FAULT, now, "; ".join(dict.fromkeys(problems)), info)
        return Health(HealthState.OK, now, "", info)
