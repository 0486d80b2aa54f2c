"""Compare a replay's log with the original: the first divergence, or "identical".

Compared, message by message and field by field (times included):

* every step's commands and device reads (``/replay/steps``): each velocity
  reference and device command sent, and each device call made, at the step
  it was made;
* the decisions: lifecycle changes (``/supervisor/state``), tree status
  changes (``/tree``), blackboard changes, events (minus the simulator's own
  ``sim`` events, which come from its ground truth, not from the supervisor),
  the result (outcome, cause, duration, action switches, closest approach to
  the limits);
* the references and what was logged of them: KCL telemetry (``/kcl``: action,
  transition, per-task activation, error and reference), safety margins, the
  logged commands and readings.

``tolerance`` 0 means bit for bit (``-0.0`` differs from ``0.0``, NaN equals
NaN). A positive tolerance accepts numbers within ``tolerance * max(1, |a|, |b|)``
(for logs replayed on another machine; see docs/replay.md); strings, flags and
statuses are always compared exactly.
"""

from __future__ import annotations

import bisect
import math
from dataclasses import dataclass, field
from typing import Any

import orjson

from mission.replay.schema import STEP_TOPIC

#: Topics compared message by message, in the order divergences at one step are listed.
TOPICS = (
    "/supervisor/state",
    "/tree",
    "/events",
    "/blackboard",
    "/kcl",
    "/vehicle/command",
    "/arm/command",
    "/safety/margins",
    "/vehicle/navigation",
    "/arm/state",
    "/gripper/state",
    "/wrench",
    "/detector",
    "/devices/health",
    "/operator/teleop",
    "/run/result",
)
COMMANDS = "commands"
READS = "device reads"
_ORDER = {
    name: i
    for i, name in enumerate(
        ("/supervisor/state", "/tree", "/events", "/blackboard", COMMANDS, "/kcl", *TOPICS[5:], READS)
    )
}
#: Result metrics that depend on the run itself (not on wall time or simulator truth).
RESULT_METRICS = ("closest_to_limits", "closest_to_limits_t", "t0", "steps", "fault_count")


@dataclass
class Divergence:
    """Where two logs first differ on one channel."""

    channel: str
    step: int
    t: float
    #: Which field (``velocity[2]``), call (``arm.command_joint_velocity values[3]``) or message.
    what: str
    logged: Any
    replay: Any

    def describe(self) -> str:
        return f"{self.channel} {self.what}: logged {_show(self.logged)}, replay {_show(self.replay)}"


@dataclass
class Comparison:
    identical: bool
    #: The earliest divergence (by step, then channel order), None when identical.
    first: Divergence | None
    #: Every channel's first divergence, earliest first.
    divergences: list[Divergence] = field(default_factory=list)
    #: Messages (or steps) compared per channel.
    counts: dict[str, int] = field(default_factory=dict)
    #: Time (s, backend clock) up to which the logs were compared (inf: to the end).
    horizon: float = math.inf
    tolerance: float = 0.0
    #: Fields the replay logged that the original does not have (``topic field``), when
    #: the comparison was told the original was written by other code.
    new_fields: list[str] = field(default_factory=list)

    @property
    def at_first_step(self) -> list[Divergence]:
        return [d for d in self.divergences if self.first is not None and d.step == self.first.step]


def _show(v: Any) -> str:
    if isinstance(v, float):
        return repr(v)
    text = repr(v)
    return text if len(text) <= 160 else text[:157] + "..."


def _same_number(a: float, b: float, tol: float) -> bool:
    if a == b:
        return tol > 0 or a != 0 or math.copysign(1.0, a) == math.copysign(1.0, b)
    if a != a and b != b:  # NaN
        return True
    if tol > 0 and math.isfinite(a) and math.isfinite(b):
        return abs(a - b) <= tol * max(1.0, abs(a), abs(b))
    return False


def first_difference(
    a: Any, b: Any, tol: float = 0.0, path: str = "", new_fields: set[str] | None = None
) -> tuple[str, Any, Any] | None:
    """``(path, a_part, b_part)`` of the first difference, or None. With
    ``new_fields`` (a set), a mapping key only ``b`` has is not a difference: its
    path (list indices as ``[]``) is added to the set instead."""
    if isinstance(a, bool) or isinstance(b, bool):
        return None if type(a) is type(b) and a == b else (path, a, b)
    if isinstance(a, (int, float)) and isinstance(b, (int, float)):
        return None if _same_number(float(a), float(b), tol) else (path, a, b)
    if isinstance(a, dict) and isinstance(b, dict):
        for k in list(a) + [k for k in b if k not in a]:
            where = f"{path}.{k}" if path else str(k)
            if k not in a and new_fields is not None:
                new_fields.add(_field_name(where))
                continue
            if k not in a or k not in b:
                return (where, a.get(k, "<absent>"), b.get(k, "<absent>"))
            d = first_difference(a[k], b[k], tol, where, new_fields)
            if d is not None:
                return d
        return None
    if isinstance(a, list) and isinstance(b, list):
        for i, (x, y) in enumerate(zip(a, b)):
            d = first_difference(x, y, tol, f"{path}[{i}]", new_fields)
            if d is not None:
                return d
        if len(a) != len(b):
            return (f"{path} length", len(a), len(b))
        return None
    return None if a == b else (path, a, b)


def _field_name(path: str) -> str:
    """A field's path without list indices (``tasks.x.commanded_rate``)."""
    out, depth = [], 0
    for ch in path:
        if ch == "[":
            depth += 1
            out.append("[]")
        elif ch == "]":
            depth -= 1
        elif depth == 0:
            out.append(ch)
    return "".join(out)


def _collapse(names: set[str]) -> list[str]:
    """Field paths with the keys of one mapping folded: ``tasks.a.x`` and
    ``tasks.b.x`` -> ``tasks.*.x``."""
    groups: dict[tuple[str, str], set[str]] = {}
    for name in names:
        parts = name.split(".")
        key = (parts[0], ".".join(parts[2:])) if len(parts) >= 3 else (name, "")
        groups.setdefault(key, set()).add(name)
    out = set()
    for (head, tail), members in groups.items():
        out |= {f"{head}.*.{tail}"} if tail and len(members) > 1 else members
    return sorted(out)


def _normalize(topic: str, msg: dict) -> dict:
    if topic == "/run/result":
        return {
            "t": msg.get("t"),
            **{k: msg.get(k) for k in ("outcome", "duration_s", "failure_cause", "actions")},
            "metrics": {k: (msg.get("metrics") or {}).get(k) for k in RESULT_METRICS},
        }
    return msg


def _reported_as_logged(logged: Any, replayed: Any) -> Any:
    """The replay's KCL telemetry without the fields the logged message lacks (reports
    added to the telemetry since the log was written, e.g. ``limited``); a field the
    replay lacks still differs."""
    if not (isinstance(logged, dict) and isinstance(replayed, dict)):
        return replayed
    return {k: _reported_as_logged(logged[k], v) for k, v in replayed.items() if k in logged}


def _message_label(msg: dict) -> str:
    for key in ("kind", "state", "root_status", "action"):
        if key in msg:
            return f"{key}={msg[key]!r}"
    return ""


def _call_label(a: list, b: list, path: str, av: Any, bv: Any) -> tuple[str, Any, Any]:
    """Name the call a difference inside a step's list of reads or commands is in."""
    idx = path[1:].split("]")[0] if path.startswith("[") else ""
    if not idx.isdigit():
        return path, av, bv
    i = int(idx)
    if i >= len(a) or i >= len(b) or a[i].get("call") != b[i].get("call"):
        return (
            f"call #{i} of the step",
            a[i].get("call") if i < len(a) else "<none>",
            b[i].get("call") if i < len(b) else "<none>",
        )
    return f"{a[i].get('call', '?')} {path[len(idx) + 3 :] or '(call)'}".strip(), av, bv


def _topic_sequences(orig: Any, replay: Any, topic: str) -> tuple[list, list, bool]:
    """Both sides of ``topic``: raw bytes (compared as bytes first) or, for topics
    that need filtering or trimming, decoded messages (``decoded`` True)."""
    if topic in ("/events", "/run/result"):
        a = [_normalize(topic, m) for m in orig.messages(topic) if m.get("kind") != "sim"]
        b = [_normalize(topic, m) for m in replay.messages(topic) if m.get("kind") != "sim"]
        return a, b, True
    return orig.raw(topic), replay.raw(topic), False


def _steps(log: Any) -> tuple[list[dict], list[int]]:
    """The steps of a log's input record and, for each, the index of the message holding it."""

    steps: list[dict] = []
    index: list[int] = []
    for i, data in enumerate(log.raw(STEP_TOPIC)):
        batch = orjson.loads(data).get("steps", ())
        steps += batch
        index += [i] * len(batch)
    return steps, index


def compare_logs(
    orig: Any, replay: Any, *, horizon_step: int | None = None, tolerance: float = 0.0, other_code: bool = False
) -> Comparison:
    """Compare two :class:`mission.replay.rawlog.RawLog` (the run's and its replay's).

    ``horizon_step``: compare only up to the end of this step of the original
    (a log cut short, or a replay stopped by the end of the log). ``other_code``:
    the original was written by other code, which may log fewer fields: a field
    only the replay has is listed in :attr:`Comparison.new_fields`, not a divergence."""

    (osteps, oidx), (rsteps, ridx) = _steps(orig), _steps(replay)
    obatch, rbatch = orig.raw(STEP_TOPIC), replay.raw(STEP_TOPIC)
    times = [float(m["t"]) for m in osteps]
    last = len(osteps) - 1
    horizon = math.inf if horizon_step is None else times[horizon_step]

    def step_of(t: float) -> int:
        return min(bisect.bisect_left(times, t), max(last, 0))

    divs: list[Divergence] = []
    counts: dict[str, int] = {}
    # --- every step: commands and device reads
    end = max(last, len(rsteps) - 1) if horizon_step is None else horizon_step
    found: dict[str, Divergence] = {}
    n = 0
    for s in range(end + 1):
        if s >= len(osteps) or s >= len(rsteps):  # one run went on longer than the other
            t = times[min(s, last)] if s <= last else float(rsteps[s]["t"])
            for ch in (COMMANDS, READS):
                found.setdefault(
                    ch,
                    Divergence(
                        ch,
                        s,
                        t,
                        f"step {s}",
                        "present" if s < len(osteps) else "absent",
                        "present" if s < len(rsteps) else "absent",
                    ),
                )
            break
        n += 1
        if oidx[s] == ridx[s] and obatch[oidx[s]] == rbatch[ridx[s]]:  # same bytes: same steps, bit for bit
            continue
        o, r = osteps[s], rsteps[s]
        for ch, key in ((COMMANDS, "commands"), (READS, "reads")):
            if ch not in found:
                a, b = o.get(key, []), r.get(key, [])
                d = first_difference(a, b, tolerance)
                if d is not None:
                    found[ch] = Divergence(ch, s, times[s], *_call_label(a, b, *d))
        if COMMANDS in found and READS in found:
            break
    counts["steps"] = n
    divs += found.values()
    # --- decision and reference topics
    new_fields: list[str] = []
    for topic in TOPICS:
        a, b, decoded = _topic_sequences(orig, replay, topic)
        compared = 0
        added: set[str] | None = set() if other_code else None
        for i, (x, y) in enumerate(zip(a, b)):
            if not decoded and x == y:
                compared += 1
                continue
            if not decoded:
                x, y = orjson.loads(x), orjson.loads(y)
            if topic == "/kcl":
                y = _reported_as_logged(x, y)
            t = min(float(x.get("t", 0.0)), float(y.get("t", 0.0)))
            if t > horizon:
                break
            compared += 1
            d = first_difference(x, y, tolerance, "", added)
            if d is not None:
                path, av, bv = d
                label = _message_label(x)
                divs.append(
                    Divergence(topic, step_of(t), t, f"{path} (message {i}{', ' + label if label else ''})", av, bv)
                )
                break
        else:
            if len(a) != len(b):
                i = min(len(a), len(b))
                extra = (a if len(a) > len(b) else b)[i]
                if not decoded:
                    extra = orjson.loads(extra)
                t = float(extra.get("t", 0.0))
                if t <= horizon:
                    side = "only in the log" if len(a) > len(b) else "only in the replay"
                    label = _message_label(extra)
                    divs.append(
                        Divergence(
                            topic,
                            step_of(t),
                            t,
                            f"message {i} {side}{' (' + label + ')' if label else ''}",
                            extra if len(a) > len(b) else "<none>",
                            "<none>" if len(a) > len(b) else extra,
                        )
                    )
        counts[topic] = compared
        new_fields += [f"{topic} {name}" for name in _collapse(added or set())]
    divs.sort(key=lambda d: (d.step, _ORDER.get(d.channel, 99)))
    return Comparison(
        identical=not divs,
        first=divs[0] if divs else None,
        divergences=divs,
        counts=counts,
        horizon=horizon,
        tolerance=tolerance,
        new_fields=new_fields,
    )
