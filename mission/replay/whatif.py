"""What an open-loop what-if changed: commands and decisions, side by side.

In an open-loop replay the inputs are the logged ones whatever the changed
mission or controller commands: the world does not react. The differences are
therefore "what the supervisor would have decided and commanded at each step,
given what it saw in the run", exact up to the first divergence and
increasingly hypothetical after it (the real vehicle would have moved
differently and seen something else).

:func:`command_series` gives the velocity references of every step (the last
command of the step, rad/s or m/s); :func:`summarize` the per-DOF differences,
the actions started, the lifecycle and the events found in only one of the logs.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from hal.interfaces import VEHICLE_DOFS
from mission.replay.schema import HEADER_TOPIC, record_steps

VEHICLE_CALL = "vehicle.command_body_velocity"
ARM_CALL = "arm.command_joint_velocity"
OPEN_LOOP_NOTE = (
    "open loop: the logged inputs are replayed as they were; the world does not react to the changed "
    "commands, so after the first difference the results say what the supervisor would have commanded "
    "given what it saw in the run, not what the vehicle would have done"
)


def command_series(log: Any, call: str) -> tuple[np.ndarray, np.ndarray]:
    """Times (s since the first step) and values (steps x dims) of the last ``call``
    command of each step, held from the previous step when a step sent none (zeros before any)."""
    steps = record_steps(log)
    if not steps:
        return np.zeros(0), np.zeros((0, 0))
    t0 = float(steps[0]["t"])
    rows: list[list[float] | None] = []
    width = 0
    for m in steps:
        last = None
        for c in m.get("commands", ()):
            if c.get("call") == call and "values" in c:
                last = [np.nan if v is None else v for v in c["values"]]
        if last is not None:
            width = max(width, len(last))
        rows.append(last)
    out = np.zeros((len(rows), width))
    prev = np.zeros(width)
    for i, r in enumerate(rows):
        if r is not None:
            prev = np.zeros(width)
            prev[: len(r)] = r
        out[i] = prev
    return np.array([float(m["t"]) for m in steps]) - t0, out


def _events(log: Any, kind: str | None = None) -> list[tuple[float, str, str]]:
    return [
        (float(m["t"]), m.get("kind", ""), m.get("message", ""))
        for m in log.messages("/events")
        if m.get("kind") != "sim" and (kind is None or m.get("kind") == kind)
    ]


def summarize(orig: Any, replay: Any, comparison: Any) -> dict:
    """JSON-able summary of the differences between a log and its what-if replay."""
    steps = record_steps(orig)
    t0 = float(steps[0]["t"]) if steps else 0.0
    header = (orig.messages(HEADER_TOPIC) or [{}])[0]
    names = {VEHICLE_CALL: list(VEHICLE_DOFS), ARM_CALL: list(header.get("joint_names", ()))}
    commands: dict[str, Any] = {}
    for call in (VEHICLE_CALL, ARM_CALL):
        ta, a = command_series(orig, call)
        tb, b = command_series(replay, call)
        n = min(len(a), len(b))
        if n == 0 or a.shape[1] != b.shape[1]:
            continue
        diff = b[:n] - a[:n]
        absd = np.abs(np.nan_to_num(diff, nan=np.inf))
        imax = np.argmax(absd, axis=0)
        labels = names[call] if len(names[call]) == a.shape[1] else [str(i) for i in range(a.shape[1])]
        changed = np.nonzero(np.any(diff != 0, axis=1))[0]
        commands[call] = {
            "dofs": labels,
            "max_abs_diff": [float(absd[i, j]) for j, i in enumerate(imax)],
            "t_of_max_s": [float(ta[i]) for i in imax],
            "rms_diff": [float(x) for x in np.sqrt(np.nanmean(diff**2, axis=0))],
            "rms_logged": [float(x) for x in np.sqrt(np.nanmean(a[:n] ** 2, axis=0))],
            "steps_compared": int(n),
            "steps_different": int(len(changed)),
            "first_different_t_s": float(ta[changed[0]]) if len(changed) else None,
        }

    def actions(log: Any) -> list[tuple[float, str]]:
        return [
            (round(t - t0, 3), msg.removeprefix("action ").removesuffix(" started"))
            for t, _, msg in _events(log, "action_start")
        ]

    def states(log: Any) -> list[tuple[float, str]]:
        return [(round(float(m["t"]) - t0, 3), m.get("state", "")) for m in log.messages("/supervisor/state")]

    ea = {(round(t, 9), k, m) for t, k, m in _events(orig)}
    eb = {(round(t, 9), k, m) for t, k, m in _events(replay)}
    only = {
        side: sorted((round(t - t0, 3), k, m) for t, k, m in evs)
        for side, evs in (("log", ea - eb), ("replay", eb - ea))
    }
    first = comparison.first
    return {
        "open_loop": OPEN_LOOP_NOTE,
        "first_divergence": None
        if first is None
        else {"step": first.step, "t_s": round(first.t - t0, 6), "channel": first.channel, "what": first.what},
        "commands": commands,
        "actions": {"log": actions(orig), "replay": actions(replay)},
        "states": {"log": states(orig), "replay": states(replay)},
        "events_only_in": only,
    }
