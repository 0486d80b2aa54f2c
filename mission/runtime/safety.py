"""Safety monitors run by the supervisor every cycle.

Pure checks over one :class:`Snapshot` of the devices (readings plus health)
return :class:`Breach` values; :class:`SafetyMonitor` is the thin stateful shell
(it remembers whether a velocity stream was ever present, so a DVL that drops
out is caught even though navigation keeps coming from the AHRS).

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
* ``warn``: logged, nothing else (a sensor is lost that the mission does not
  watch: e.g. the DVL, whose loss only ends the run through the ``dvl_velocity``
  watchdog when the mission watches ``navigation``; an operator input lost: a
  gamepad unplugged, whose commands then age past the teleop's dead-man).

Device health is classified by what failed, not by which driver reported it:
the vehicle's parts (``Health.info`` entries with a ``state``, see
:func:`hal.check.parts_of`) tell the autopilot link from the DVL and the AHRS.

Per step the supervisor first runs :meth:`SafetyMonitor.quick_margins`, a fast
path that only says "certainly no breach" (and gives the margins); whenever it
cannot, the full :meth:`SafetyMonitor.check` on a :class:`Snapshot` decides, so
both give the same breaches, margins and closest approaches (a property test
checks it: ``tests/runtime/test_safety_fast_path.py``).

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
from typing import Any, NamedTuple

import numpy as np

from hal.check import parts_of
from hal.config_schema import OPERATOR_ROLES
from hal.interfaces import Health, HealthState, JointState, NavigationState

_INF = math.inf


class PolledDevices(NamedTuple):
    """What the last poll of the devices found (at the tree rate:
    :meth:`mission.runtime.inputs.DevicePoller.read`)."""

    #: Devices whose health is FAULT or MISSING, by role.
    bad: dict[str, Health]
    #: Time (backend clock, s) of the latest reading of each watched slow stream
    #: (``gripper``, ``wrench``, ``detector``), None while there is none.
    stream_times: dict[str, float | None]
    #: The gripper's fault text (None: no fault, or no gripper watched).
    gripper_fault: str | None


class WatchPlan(NamedTuple):
    """:attr:`SafetyMonitor.watchdog_s` laid out for the fast path: ``(code, stream,
    limit_s)`` per watched stream, code 0 navigation, 1 joints, 2 the DVL velocity,
    3 another stream, in the dict's order."""

    #: The watchdog table the plan was made from (a new table needs a new plan).
    watchdog_s: dict[str, float]
    entries: tuple[tuple[int, str, float], ...]


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


@dataclass
class Snapshot:
    """What the monitors look at in one cycle; times in s on the backend clock."""

    now: float
    elapsed: float
    nav: NavigationState | None
    joints: JointState | None
    stream_times: Mapping[str, float | None] = field(default_factory=dict)
    health: Mapping[str, Health] = field(default_factory=dict)
    commands: Mapping[str, np.ndarray | None] = field(default_factory=dict)
    gripper_fault: str | None = None


def all_finite(x: Any) -> bool:
    """True for None, finite numbers and arrays with only finite entries (fast path: ndarray)."""
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


def check_non_finite(s: Snapshot) -> list[Breach]:
    """NaN/inf in navigation, joint readings or outgoing commands."""
    out = []
    if s.nav is not None:
        for name in ("position", "attitude", "body_velocity"):
            if not all_finite(getattr(s.nav, name)):
                out.append(Breach("non_finite", "navigation", f"non-finite {name}: {getattr(s.nav, name)}"))
        if not all_finite(s.nav.depth):
            out.append(Breach("non_finite", "navigation", f"non-finite depth: {s.nav.depth}"))
    if s.joints is not None:
        for name in ("position", "velocity"):
            if not all_finite(getattr(s.joints, name)):
                out.append(Breach("non_finite", "joints", f"non-finite joint {name}: {getattr(s.joints, name)}"))
    for name, cmd in s.commands.items():
        if not all_finite(cmd):
            out.append(Breach("non_finite", name, f"non-finite {name} command: {cmd}"))
    return out


def check_watchdogs(s: Snapshot, watchdog_s: Mapping[str, float]) -> list[Breach]:
    """Each watched stream's latest reading must be younger than its limit."""
    out = []
    for stream, limit in watchdog_s.items():
        if stream not in s.stream_times:
            continue
        t = s.stream_times[stream]
        if t is None:
            out.append(Breach("watchdog", stream, f"no {stream} reading (limit {limit:.3g} s)"))
            continue
        age = s.now - t
        if not math.isfinite(age) or age > limit:
            out.append(Breach("watchdog", stream, f"{stream} reading is {age:.3f} s old (limit {limit:.3g} s)"))
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


def check_drive_faults(s: Snapshot) -> list[Breach]:
    """Devices reporting FAULT/MISSING (classified), joint or gripper faults; one breach per
    (kind, source): a faulted joint shows in the arm's health and in the joint state, once."""
    out: dict[tuple[str, str], Breach] = {}
    for role, h in s.health.items():
        for b in classify_health(role, h):
            out.setdefault((b.kind, b.source), b)
    if s.joints is not None and s.joints.fault:
        out.setdefault(("drive_fault", "arm"), Breach("drive_fault", "arm", f"joint fault: {s.joints.fault}"))
    if s.gripper_fault:
        out.setdefault(
            ("gripper_fault", "gripper"), Breach("gripper_fault", "gripper", f"gripper fault: {s.gripper_fault}")
        )
    return list(out.values())


def geofence_margin(geofence: Any, position: Any) -> float:
    """Distance (m) from ``position`` (world NED) to the nearest geofence face; negative outside."""
    x, y, z = (float(v) for v in position[:3])
    (n0, n1), (e0, e1), (d0, d1) = geofence.north_m, geofence.east_m, geofence.down_m
    return min(x - n0, n1 - x, y - e0, e1 - y, z - d0, d1 - z)


def envelope_margins(s: Snapshot, safety: Any) -> dict[str, float]:
    """Margins (positive inside) to depth (m), altitude (m), duration (s), geofence (m)."""
    m: dict[str, float] = {"duration_s": float(safety.max_duration_s - s.elapsed)}
    if s.nav is not None:
        m["depth_m"] = float(safety.max_depth_m - s.nav.depth)
        if s.nav.altitude is not None:
            m["altitude_m"] = float(s.nav.altitude - safety.min_altitude_m)
        if getattr(safety, "geofence", None) is not None:
            m["geofence_m"] = geofence_margin(safety.geofence, s.nav.position)
    return m


def joint_limit_margin(q: np.ndarray, lower: np.ndarray, upper: np.ndarray) -> float:
    """Smallest distance (rad) of any joint to its lower/upper limit; negative beyond."""
    return float(min((q - lower).min(), (upper - q).min()))


class LimitLists(NamedTuple):
    """Joint limits (rad) as Python lists."""

    lower: list[float]
    upper: list[float]


class JointLimits:
    """A model's joint limits (rad) for the per-step :func:`joint_limit_margin`; for
    positions known to be finite (:meth:`margin` with ``finite=True``) the same
    number without numpy (the limits kept as lists, unless one is NaN)."""

    def __init__(self, lower: np.ndarray, upper: np.ndarray) -> None:
        self.lower, self.upper = lower, upper
        lo = np.asarray(lower, dtype=float).ravel().tolist()
        up = np.asarray(upper, dtype=float).ravel().tolist()
        usable = bool(lo) and not any(v != v for v in lo + up)
        #: The limits as lists for the fast margin (None: empty, or a NaN limit).
        self._lists: LimitLists | None = LimitLists(lo, up) if usable else None

    def margin(self, q: np.ndarray, finite: bool = False) -> float:
        """:func:`joint_limit_margin` of joint positions ``q`` (rad); ``finite``: the
        caller checked that every entry of ``q`` is finite."""
        lists = self._lists
        if finite and lists is not None:
            ql = q.tolist()
            if len(ql) == len(lists.lower):
                return min(min(map(sub, ql, lists.lower)), min(map(sub, lists.upper, ql)))
        return joint_limit_margin(q, self.lower, self.upper)


ENVELOPE_TEXT = {
    "duration_s": "mission duration limit exceeded",
    "depth_m": "deeper than the maximum depth",
    "altitude_m": "closer to the bottom than the minimum altitude",
    "geofence_m": "outside the geofence",
}


def check_envelope(margins: Mapping[str, float]) -> list[Breach]:
    return [
        Breach("envelope", name, f"{ENVELOPE_TEXT[name]} (margin {value:.3f})")
        for name, value in margins.items()
        if name in ENVELOPE_TEXT and math.isfinite(value) and value < 0.0
    ]


#: Watchdog key of the DVL body-velocity stream (watched once a velocity was seen).
VELOCITY_STREAM = "dvl_velocity"


class SafetyMonitor:
    """Runs every check on each snapshot; remembers streams seen so far.

    The mission's ``navigation`` watchdog applies to the navigation solution
    (pose/attitude). The DVL velocity inside it is watched separately, as
    :data:`VELOCITY_STREAM`, with ``velocity_watchdog_s`` (never below the
    navigation limit): DVL pings come at a few Hz and a single lost ping is
    normal, whereas the pose comes at the AHRS rate. A vehicle without a DVL
    (velocity never seen) is not watched for velocity.
    """

    def __init__(self, safety: Any, velocity_watchdog_s: float = 1.0) -> None:
        self.safety = safety
        self.watchdog_s: dict[str, float] = dict(getattr(safety, "watchdog_s", {}) or {})
        if "navigation" in self.watchdog_s:
            self.watchdog_s[VELOCITY_STREAM] = max(velocity_watchdog_s, self.watchdog_s["navigation"])
        self._velocity_seen = False
        #: Smallest margin seen per limit, and the elapsed time (s) it was seen at.
        self.closest: dict[str, float] = {}
        self.closest_t: dict[str, float] = {}
        self._fence: Any = None  # the geofence whose bounds quick_margins() holds
        self._fence_bounds: tuple = ()
        self._plan: WatchPlan | None = None  # for quick_margins()

    def stream_times(self, nav: NavigationState | None, others: Mapping[str, float | None]) -> dict[str, float | None]:
        """Latest reading time per watched stream (navigation pose and DVL velocity apart)."""
        times = dict(others)
        if nav is not None:
            times["navigation"] = nav.t
            if nav.velocity_t is not None and nav.body_velocity is not None:
                self._velocity_seen = True
            if self._velocity_seen:
                times[VELOCITY_STREAM] = nav.velocity_t if nav.body_velocity is not None else None
        return times

    def record(self, name: str, margin: float, elapsed: float) -> None:
        """Keep ``margin`` if it is the closest approach to limit ``name`` so far
        (a NaN margin, e.g. before the first position fix, is never kept: it
        would compare false with every later value)."""
        if margin != margin:
            return
        if name not in self.closest or margin < self.closest[name]:
            self.closest[name] = margin
            self.closest_t[name] = elapsed

    def quick_margins(
        self, now: float, elapsed: float, nav: Any, js: Any, polled: PolledDevices
    ) -> dict[str, float] | None:
        """The per-step fast path of :meth:`check`: the margins (recorded as :meth:`check`
        records them) when this step certainly has no breach, else None and nothing
        recorded (the caller then runs :meth:`check` on the full :class:`Snapshot`,
        which decides). ``polled``: :attr:`mission.runtime.inputs.DevicePoller.polled`.

        Cheap and conservative: one sum over every navigation and joint value (finite
        iff all are; an overflow or a value of another type only sends the step to
        :meth:`check`), the watched streams' ages, the envelope margins; no
        :class:`Snapshot`, no lists of breaches."""
        bad, others, gripper_fault = polled
        if bad or gripper_fault or nav is None or js is None or js.fault:
            return None
        bv = nav.body_velocity
        try:
            pos = nav.position.tolist()
            total = (
                sum(pos)
                + sum(nav.attitude.tolist())
                + nav.depth
                + sum(js.position.tolist())
                + sum(js.velocity.tolist())
            )
            if bv is not None:
                total += sum(bv.tolist())
        except (AttributeError, TypeError):
            return None
        if not -_INF < total < _INF:
            return None
        if nav.velocity_t is not None and bv is not None:
            self._velocity_seen = True
        plan = self._plan
        if plan is None or plan.watchdog_s is not self.watchdog_s:
            plan = self._plan = WatchPlan(self.watchdog_s, self._watch_plan())
        for code, stream, limit in plan.entries:  # check_watchdogs over stream_times()
            if code == 0:
                t = nav.t
            elif code == 1:
                t = js.t
            elif code == 2:
                if not self._velocity_seen:
                    continue
                t = nav.velocity_t if bv is not None else None
            elif stream in others:
                t = others[stream]
            else:
                continue
            if t is None:
                return None
            age = now - t
            if not (-_INF < age < _INF and age <= limit):
                return None
        safety = self.safety  # envelope_margins, then check_envelope: no negative finite margin
        duration = float(safety.max_duration_s - elapsed)
        depth = float(safety.max_depth_m - nav.depth)
        if -_INF < duration < 0.0 or -_INF < depth < 0.0:
            return None
        m: dict[str, float] = {"duration_s": duration, "depth_m": depth}
        if nav.altitude is not None:
            altitude = float(nav.altitude - safety.min_altitude_m)
            if -_INF < altitude < 0.0:
                return None
            m["altitude_m"] = altitude
        fence = getattr(safety, "geofence", None)
        if fence is not None:  # geofence_margin()
            if fence is not self._fence:
                self._fence = fence
                (n0, n1), (e0, e1), (d0, d1) = fence.north_m, fence.east_m, fence.down_m
                self._fence_bounds = (n0, n1, e0, e1, d0, d1)
            n0, n1, e0, e1, d0, d1 = self._fence_bounds
            x, y, z = pos[0], pos[1], pos[2]
            g = min(x - n0, n1 - x, y - e0, e1 - y, z - d0, d1 - z)
            if -_INF < g < 0.0:
                return None
            m["geofence_m"] = g
        closest, closest_t = self.closest, self.closest_t
        for k, v in m.items():  # record(k, v, elapsed), inline
            if v == v and (k not in closest or v < closest[k]):
                closest[k] = v
                closest_t[k] = elapsed
        return m

    def _watch_plan(self) -> tuple[tuple[int, str, float], ...]:
        """The entries of a :class:`WatchPlan` of :attr:`watchdog_s`."""
        codes = {"navigation": 0, "joints": 1, VELOCITY_STREAM: 2}
        return tuple((codes.get(stream, 3), stream, limit) for stream, limit in self.watchdog_s.items())

    def check(self, s: Snapshot) -> tuple[list[Breach], dict[str, float]]:
        """All breaches in this snapshot and the current margins."""
        margins = envelope_margins(s, self.safety)
        for k, v in margins.items():
            self.record(k, v, s.elapsed)
        breaches = (
            check_non_finite(s) + check_drive_faults(s) + check_watchdogs(s, self.watchdog_s) + check_envelope(margins)
        )
        return breaches, margins
