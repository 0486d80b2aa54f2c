"""Safety monitors run by the supervisor every cycle.

:meth:`SafetyMonitor.check` looks at one step's readings (navigation, joints)
and the last poll of the devices (:class:`PolledDevices`) and returns the
violated rules as :class:`Breach` values with the margins to every limit. It
remembers whether a velocity stream was ever present, so a DVL that drops out
is caught even though navigation keeps coming from the AHRS. The same call
serves the preflight and every loop step; a step without a breach costs one
sum over the readings, the watched streams' ages and the envelope margins.

Every breach carries its **ending** (the fault table of ``docs/faults.md``, the
same for real and simulated devices; :func:`ending_of`):

* ``stop``: unsafe to move: immediate safe stop, no abort path (non-finite
  values, an arm drive fault, the vehicle's autopilot link lost, stale joints);
* ``abort_short``: the abort path, cut short after ``short_abort_s`` (the
  vehicle's attitude is lost or stale: AHRS lost, navigation watchdog);
* ``abort``: the mission's abort path (envelope, DVL velocity watchdog, other
  watched streams);
* ``leaf``: only the leaf using the device fails, so retry/fallback get their
  chance (a gripper fault);
* ``warn``: logged, nothing else (a sensor the mission does not watch is lost,
  e.g. the DVL, or an operator input such as an unplugged gamepad, whose
  commands then age past the teleop's dead-man).

Device health is classified by what failed, not by which driver reported it:
the vehicle's parts (``Health.info`` entries with a ``state``, see
:func:`hal.check.parts_of`) tell the autopilot link from the DVL and the AHRS.

Limits come from the mission's :class:`mission.spec.Safety` (duck-typed here:
``max_depth_m``, ``min_altitude_m``, ``max_duration_s``, ``geofence`` with
``north_m/east_m/down_m`` ``(low, high)`` bounds in world NED, ``watchdog_s``
stream -> max age in s). Margins are distances to each limit in its own unit,
positive while inside.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from operator import sub
from typing import Any

import numpy as np

from hal.check import parts_of
from hal.config_schema import OPERATOR_ROLES
from hal.interfaces import Health, HealthState, JointState, NavigationState

_INF = math.inf


@dataclass(frozen=True, slots=True)
class PolledDevices:
    """What the last poll of the devices found (at the tree rate:
    :meth:`mission.runtime.inputs.DevicePoller.read`)."""

    #: Devices whose health is FAULT or MISSING, by role.
    bad: Mapping[str, Health] = field(default_factory=dict)
    #: Time (backend clock, s) of the latest reading of each watched slow stream
    #: (``gripper``, ``wrench``, ``detector``), None while there is none.
    stream_times: Mapping[str, float | None] = field(default_factory=dict)
    #: The gripper's fault text (None: no fault, or no gripper watched).
    gripper_fault: str | None = None


#: Endings, mildest first (see the module docstring).
ENDINGS = ("warn", "leaf", "abort", "abort_short", "stop")
#: Endings that interrupt the mission.
INTERRUPTING = ("abort", "abort_short", "stop")


@dataclass(frozen=True)
class Breach:
    """One violated safety rule. ``kind``: watchdog, envelope, drive_fault, non_finite,
    vehicle_link, sensor_lost, gripper_fault, operator_input; ``ending``: one of :data:`ENDINGS`."""

    kind: str
    source: str
    message: str
    ending: str = ""

    def __post_init__(self) -> None:
        if not self.ending:
            object.__setattr__(self, "ending", ending_of(self.kind, self.source))

    def __str__(self) -> str:
        return f"{self.kind} ({self.source}): {self.message}"


#: (kind, source) -> ending; source "*" matches any source of that kind.
FAULT_TABLE: dict[tuple[str, str], str] = {
    ("non_finite", "*"): "stop",
    ("drive_fault", "*"): "stop",
    ("vehicle_link", "*"): "stop",
    ("watchdog", "joints"): "stop",
    ("sensor_lost", "ahrs"): "abort_short",
    ("watchdog", "navigation"): "abort_short",
    ("watchdog", "*"): "abort",
    ("envelope", "*"): "abort",
    ("gripper_fault", "*"): "leaf",
    ("sensor_lost", "*"): "warn",
    ("operator_input", "*"): "warn",
}


def ending_of(kind: str, source: str) -> str:
    """The fault table's ending for a breach (unknown kinds: ``stop``, the safe side)."""
    return FAULT_TABLE.get((kind, source)) or FAULT_TABLE.get((kind, "*")) or "stop"


def worst(breaches: list[Breach]) -> Breach | None:
    """The breach with the most severe ending (the first of equals), None for an empty list."""
    return max(breaches, key=lambda b: ENDINGS.index(b.ending), default=None)


def all_finite(x: Any) -> bool:
    """True for None, finite numbers and arrays with only finite entries."""
    if x is None:
        return True
    if isinstance(x, np.ndarray):  # small vectors: Python on a list beats a numpy ufunc call
        values = x.ravel().tolist()
        if -_INF < sum(values) < _INF:  # one sum: finite iff every entry is, unless it overflows
            return True
        return all(map(math.isfinite, values))
    if isinstance(x, (int, float)):
        return math.isfinite(x)
    return bool(np.isfinite(np.asarray(x, dtype=float)).all())


def non_finite_breaches(nav: NavigationState, js: JointState) -> list[Breach]:
    """NaN/inf in navigation or joint readings, one breach per field."""
    out = []
    for name in ("position", "attitude", "body_velocity", "depth"):
        if not all_finite(getattr(nav, name)):
            out.append(Breach("non_finite", "navigation", f"non-finite {name}: {getattr(nav, name)}"))
    for name in ("position", "velocity"):
        if not all_finite(getattr(js, name)):
            out.append(Breach("non_finite", "joints", f"non-finite joint {name}: {getattr(js, name)}"))
    return out


#: Vehicle parts that are sensors (their loss is not a loss of the vehicle): the DVL, the
#: AHRS and the Ping echosounder (an altitude source, lost as the DVL's altitude is).
VEHICLE_SENSORS = ("dvl", "ahrs", "ping")
_BAD = (HealthState.FAULT.value, HealthState.MISSING.value)


def classify_health(role: str, h: Health) -> list[Breach]:
    """Breaches for one device's unusable health (empty while usable); see the module docstring."""
    if h.state not in (HealthState.FAULT, HealthState.MISSING):
        return []
    what = f"{role} {h.state.value}: {h.detail or 'no detail'}"
    if role in OPERATOR_ROLES:  # a lost operator input stops only the operator's commands (its dead-man)
        return [Breach("operator_input", role, what)]
    if role == "arm":
        return [Breach("drive_fault", "arm", what)]
    if role == "gripper":
        return [Breach("gripper_fault", "gripper", what)]
    if role != "vehicle":  # detector, wrench sensor: the mission's watchdogs decide
        return [Breach("sensor_lost", role, what)]
    parts, _ = parts_of(h.info or {})
    bad = [p for p in parts if p.get("state") in _BAD]
    if not bad:  # nothing tells which part failed: the vehicle as a whole
        return [Breach("vehicle_link", "vehicle", what)]
    out = []
    for p in bad:
        name = str(p.get("name"))
        text = f"{name} {p.get('state')}: {p.get('detail') or 'no detail'}"
        out.append(
            Breach("sensor_lost", name, text) if name in VEHICLE_SENSORS else Breach("vehicle_link", "vehicle", text)
        )
    return out


def device_breaches(polled: PolledDevices, js: JointState) -> list[Breach]:
    """Devices reporting FAULT/MISSING (classified), joint or gripper faults; one breach per
    (kind, source): a faulted joint shows in the arm's health and in the joint state, once."""
    out: dict[tuple[str, str], Breach] = {}
    for role, h in polled.bad.items():
        for b in classify_health(role, h):
            out.setdefault((b.kind, b.source), b)
    if js.fault:
        out.setdefault(("drive_fault", "arm"), Breach("drive_fault", "arm", f"joint fault: {js.fault}"))
    if polled.gripper_fault:
        text = f"gripper fault: {polled.gripper_fault}"
        out.setdefault(("gripper_fault", "gripper"), Breach("gripper_fault", "gripper", text))
    return list(out.values())


def geofence_margin(geofence: Any, position: Any) -> float:
    """Distance (m) from ``position`` (world NED) to the nearest geofence face; negative outside."""
    x, y, z = (float(v) for v in position[:3])
    (n0, n1), (e0, e1), (d0, d1) = geofence.north_m, geofence.east_m, geofence.down_m
    return min(x - n0, n1 - x, y - e0, e1 - y, z - d0, d1 - z)


ENVELOPE_TEXT = {
    "duration_s": "mission duration limit exceeded",
    "depth_m": "deeper than the maximum depth",
    "altitude_m": "closer to the bottom than the minimum altitude",
    "geofence_m": "outside the geofence",
}

#: Watchdog key of the DVL body-velocity stream (watched once a velocity was seen).
VELOCITY_STREAM = "dvl_velocity"


class SafetyMonitor:
    """Checks each step's readings; remembers the streams seen and the closest approaches.

    The mission's ``navigation`` watchdog applies to the navigation solution
    (pose/attitude). The DVL velocity inside it is watched separately, as
    :data:`VELOCITY_STREAM`, with ``velocity_watchdog_s`` (never below the
    navigation limit): DVL pings come at a few Hz and a single lost ping is
    normal, whereas the pose comes at the AHRS rate. A vehicle without a DVL
    (velocity never seen) is not watched for velocity. ``joint_limits``: the
    model's ``(lower, upper)`` joint limits (rad) for :meth:`joint_margin`.
    """

    def __init__(
        self, safety: Any, velocity_watchdog_s: float = 1.0, joint_limits: tuple[Any, Any] | None = None
    ) -> None:
        self.safety = safety
        self.watchdog_s: dict[str, float] = dict(getattr(safety, "watchdog_s", {}) or {})
        if "navigation" in self.watchdog_s:
            self.watchdog_s[VELOCITY_STREAM] = max(velocity_watchdog_s, self.watchdog_s["navigation"])
        self._velocity_seen = False
        #: Smallest margin seen per limit, and the elapsed time (s) it was seen at.
        self.closest: dict[str, float] = {}
        self.closest_t: dict[str, float] = {}
        fence = getattr(safety, "geofence", None)
        #: The geofence as ``(n0, n1, e0, e1, d0, d1)`` (m, world NED), None without one.
        self._fence: tuple[float, ...] | None = None
        if fence is not None:
            self._fence = (*fence.north_m, *fence.east_m, *fence.down_m)
        self._joint_limits: tuple[list[float], list[float]] | None = None
        if joint_limits is not None:
            lo, up = (np.asarray(v, dtype=float).ravel().tolist() for v in joint_limits)
            self._joint_limits = (lo, up) if lo else None

    def record(self, margins: Mapping[str, float], elapsed: float) -> None:
        """Keep each of ``margins`` (limit name -> margin) that is the closest approach
        to its limit so far, seen at ``elapsed`` (s) (a NaN margin, e.g. before the first
        position fix, is never kept: it would compare false with every later value)."""
        closest, closest_t = self.closest, self.closest_t
        for name, margin in margins.items():
            if margin == margin and (name not in closest or margin < closest[name]):
                closest[name] = margin
                closest_t[name] = elapsed

    def check(
        self, now: float, elapsed: float, nav: NavigationState, js: JointState, polled: PolledDevices
    ) -> tuple[list[Breach], dict[str, float]]:
        """The breaches at backend time ``now`` (s; ``elapsed`` since the run's start) of
        this step's readings and the last poll, and the envelope margins (recorded).
        Runs every step: a step without a breach builds no :class:`Breach` and no text."""
        safety = self.safety
        margins: dict[str, float] = {
            "duration_s": float(safety.max_duration_s - elapsed),
            "depth_m": float(safety.max_depth_m - nav.depth),
        }
        if nav.altitude is not None:
            margins["altitude_m"] = float(nav.altitude - safety.min_altitude_m)
        position = nav.position.tolist()
        if self._fence is not None:
            n0, n1, e0, e1, d0, d1 = self._fence
            x, y, z = position[:3]
            margins["geofence_m"] = min(x - n0, n1 - x, y - e0, e1 - y, z - d0, d1 - z)
        self.record(margins, elapsed)
        outside = False
        for value in margins.values():
            outside = outside or -_INF < value < 0.0
        # one sum: finite iff every reading is (an overflow, or a reading of another type,
        # sends the step to the field by field check, which decides)
        bv = nav.body_velocity
        try:
            total = sum(position) + sum(nav.attitude.tolist()) + nav.depth
            total += sum(js.position.tolist()) + sum(js.velocity.tolist())
            if bv is not None:
                total += sum(bv.tolist())
        except (AttributeError, TypeError):
            total = math.nan
        breaches = [] if -_INF < total < _INF else non_finite_breaches(nav, js)
        if polled.bad or polled.gripper_fault or js.fault:
            breaches += device_breaches(polled, js)
        if nav.velocity_t is not None and bv is not None:
            self._velocity_seen = True
        others = polled.stream_times
        for stream, limit in self.watchdog_s.items():
            t: float | None
            if stream == "navigation":
                t = nav.t
            elif stream == "joints":
                t = js.t
            elif stream == VELOCITY_STREAM:
                if not self._velocity_seen:
                    continue
                t = nav.velocity_t if bv is not None else None
            elif stream in others:
                t = others[stream]
            else:  # a stream without a device is not watched
                continue
            if t is None:
                breaches.append(Breach("watchdog", stream, f"no {stream} reading (limit {limit:.3g} s)"))
            elif not -_INF < now - t <= limit:
                text = f"{stream} reading is {now - t:.3f} s old (limit {limit:.3g} s)"
                breaches.append(Breach("watchdog", stream, text))
        if outside:
            for name, value in margins.items():
                if -_INF < value < 0.0:
                    breaches.append(Breach("envelope", name, f"{ENVELOPE_TEXT[name]} (margin {value:.3f})"))
        return breaches, margins

    def joint_margin(self, q: np.ndarray, elapsed: float) -> float | None:
        """Smallest distance (rad) of any joint position ``q`` to its limits (negative
        beyond, NaN for a NaN position), recorded as ``joint_limits_rad``; None without limits."""
        limits = self._joint_limits
        if limits is None:
            return None
        ql = q.tolist()
        lower, upper = limits
        if len(ql) != len(lower):
            return math.nan
        total = sum(ql)
        if total != total:  # a NaN position (Python's min may skip it)
            return math.nan
        margin = min(min(map(sub, ql, lower)), min(map(sub, upper, ql)))
        self.record({"joint_limits_rad": margin}, elapsed)
        return margin
