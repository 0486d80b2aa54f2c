"""Read a run log back into Python dicts.

Reads the file sequentially (:class:`mission.logs.stream.LogStream`, the
``mcap`` package's stream reader), so a file cut short (a run killed mid-way)
yields everything up to the last complete chunk; :attr:`RunLog.truncated` says so. Messages are decoded JSON dicts with
their ``t`` (backend clock, s).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from mission.logs.errors import LogError
from mission.logs.stream import LogStream

__all__ = ["LogError", "RunLog", "read_log"]


@dataclass
class RunLog:
    """All messages of one run log, by topic, in log order."""

    path: Path
    topics: dict[str, list[dict]] = field(default_factory=dict)
    truncated: bool = False
    #: Why reading stopped early (empty when the file is complete).
    stop_reason: str = ""

    def messages(self, topic: str) -> list[dict]:
        return self.topics.get(topic, [])

    @property
    def t0(self) -> float:
        """Backend time (s) of the run's start (its ``/run/config`` message): 0 in the
        simulator, a monotonic clock reading on real hardware."""
        config = self.messages("/run/config")
        if config:
            return float(config[0]["t"])
        return min((msgs[0]["t"] for msgs in self.topics.values() if msgs), default=0.0)

    def series(self, topic: str, key: str) -> tuple[np.ndarray, np.ndarray]:
        """Times since the run start (s) and stacked values of ``key`` on ``topic``
        (NaN where missing/null)."""
        msgs = [m for m in self.messages(topic) if key in m]
        t = np.array([m["t"] for m in msgs], dtype=float) - self.t0
        vals = [m[key] for m in msgs]
        if not vals:
            return t, np.zeros((0,))
        width = max((len(v) if isinstance(v, list) else 1) for v in vals)
        out = np.full((len(vals), width) if any(isinstance(v, list) for v in vals) else (len(vals),), np.nan)
        for i, v in enumerate(vals):
            if isinstance(v, list):
                row = [np.nan if x is None else x for x in v]
                out[i, : len(row)] = row
            elif v is not None:
                out[i] = v
        return t, out

    @property
    def end_time(self) -> float:
        """Time of the last message since the run start, s."""
        return max((msgs[-1]["t"] for msgs in self.topics.values() if msgs), default=self.t0) - self.t0

    @property
    def result(self) -> dict | None:
        res = self.messages("/run/result")
        return res[-1] if res else None


def read_log(path: str | Path) -> RunLog:
    """Decode every JSON message of the MCAP file at ``path`` (a file cut short is
    read up to its last whole record: ``truncated`` and ``stop_reason`` say so)."""

    stream = LogStream(path)
    log = RunLog(Path(path))
    for topic, msg in stream:
        log.topics.setdefault(topic, []).append(msg)
    log.truncated, log.stop_reason = stream.truncated, stream.stop_reason
    return log
