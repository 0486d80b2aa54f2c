"""Planning a campaign: which runs, with which seeds and settings.

Per-run seeds come from ``numpy.random.SeedSequence(campaign_seed).spawn(n)``:
run ``i`` gets the same seed whatever ``n`` is, so a 1000-run campaign starts
with the same runs as a 10-run one of the same seed. Seeds are 32-bit so that
every random generator downstream accepts them.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np


@dataclass(frozen=True)
class RunSpec:
    """Everything a worker needs to perform one run (picklable, no live objects).

    ``overrides`` are dotted scenario keys (``pipe.pose.x``); ``controller`` are
    controller options (``compensation``, ``filter_cutoff_rad_s``);
    ``timeout_s`` is the run's wall-clock limit (None: none), see
    :mod:`mission.campaign.deadline`.
    """

    index: int
    seed: int
    mission_path: str
    scenario: str
    overrides: dict[str, Any] = field(default_factory=dict)
    controller: dict[str, Any] = field(default_factory=dict)
    log_path: str | None = None
    #: extra measurements to take (e.g. ``("oscillation",)``), see :mod:`.single`
    measure: tuple[str, ...] = ()
    timeout_s: float | None = None


@dataclass(frozen=True)
class CampaignPlan:
    """A campaign: its seed and its runs, ordered by index."""

    seed: int
    runs: tuple[RunSpec, ...]

    @property
    def mission_path(self) -> str:
        return self.runs[0].mission_path if self.runs else ""

    @property
    def scenario(self) -> str:
        return self.runs[0].scenario if self.runs else ""


def run_seeds(campaign_seed: int, n: int) -> list[int]:
    """The ``n`` per-run seeds (32-bit ints) derived from ``campaign_seed``."""

    if n < 0:
        raise ValueError(f"number of runs must be >= 0, got {n}")
    if campaign_seed < 0:
        raise ValueError(f"campaign seed must be >= 0, got {campaign_seed}")
    children = np.random.SeedSequence(campaign_seed).spawn(n)
    return [int(c.generate_state(1, dtype=np.uint32)[0]) for c in children]


def plan_campaign(
    mission_path: str | Path,
    scenario: str,
    runs: int,
    seed: int = 0,
    *,
    overrides: dict[str, Any] | None = None,
    controller: dict[str, Any] | None = None,
    log_dir: str | Path | None = None,
    measure: tuple[str, ...] = (),
    timeout_s: float | None = None,
) -> CampaignPlan:
    """Plan ``runs`` randomized runs of a mission on a scenario.

    With ``log_dir``, run ``i`` writes its MCAP log to ``log_dir/run_0000i.mcap``;
    ``timeout_s`` limits each run's wall-clock time (None: no limit).
    """
    seeds = run_seeds(seed, runs)
    width = max(4, len(str(max(runs - 1, 0))))
    base = RunSpec(
        0,
        0,
        str(mission_path),
        scenario,
        dict(overrides or {}),
        dict(controller or {}),
        None,
        tuple(measure),
        timeout_s,
    )
    specs = []
    for i, s in enumerate(seeds):
        log = str(Path(log_dir) / f"run_{i:0{width}d}.mcap") if log_dir is not None else None
        specs.append(replace(base, index=i, seed=s, log_path=log))
    return CampaignPlan(seed=seed, runs=tuple(specs))
