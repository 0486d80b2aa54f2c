"""One scenario parameter of the simulator (the tables of :mod:`sim_backend.schema`)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

INF = float("inf")


@dataclass(frozen=True)
class Param:
    """One scenario parameter; ``unit`` is documentation only."""

    key: str
    kind: str
    default: Any
    lo: float = -INF
    hi: float = INF
    n: int = 0
    unit: str = ""
