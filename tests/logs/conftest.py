"""Shared helpers: a small synthetic run log written by the real writer."""

from __future__ import annotations

import math

import numpy as np
import pytest

from mission.logs.writer import RunLogWriter
from mission.runtime.options import RunOptions, RunTarget


def write_synthetic_log(
    path, *, seconds: float = 6.0, hz: float = 20.0, close: bool = True, chunk_size: int | None = None
) -> RunLogWriter:
    """A run that switches survey -> grasp at 2 s and grasp -> transport at 4 s
    (``chunk_size``: the writer's, bytes; None: its default)."""
    w = RunLogWriter(path) if chunk_size is None else RunLogWriter(path, chunk_size=chunk_size)
    w.write("/run/config", 0.0, {"mission_path": "m.yaml", "mission_name": "m", "seed": 1})
    n = int(seconds * hz)
    for i in range(n):
        t = i / hz
        action = "survey" if t < 2 else ("grasp" if t < 4 else "transport")
        a_tool = min(1.0, max(0.0, (t - 2) / 0.5)) if action == "grasp" else 0.0
        w.write(
            "/kcl",
            t,
            {
                "action": action,
                "transition": 1.0,
                "tasks": {
                    "joint_limits": {"activation": [0.0, 0.2], "error": [0, 0], "reference": [0, 0]},
                    "tool_pose": {"activation": [a_tool] * 6, "error": [0.1] * 6, "reference": [0.0] * 6},
                },
            },
        )
        w.write("/vehicle/command", t, {"body_velocity": np.array([0.2 * math.sin(t), 0, 0, 0, 0, 0.05])})
        w.write(
            "/vehicle/navigation",
            t,
            {
                "position": [t, 0, 3],
                "attitude": [0, 0, 0],
                "body_velocity": np.array([0.18 * math.sin(t), 0, 0, 0, 0, 0.04]),
                "depth": 3.0,
                "altitude": 1.0,
            },
        )
        w.write("/arm/command", t, {"velocity": np.array([0.1, -0.1, 0.05, 0.0])})
        w.write("/arm/state", t, {"position": [0, 0, 0, 0], "velocity": [0.1, -0.1, 0.05, 0.0], "current": [0.3] * 4})
        w.write("/ground_truth", t, {"tool_to_target_m": 2.0 - 0.3 * t, "grasp": "none" if t < 5 else "holding"})
        w.write("/safety/margins", t, {"margins": {"depth_m": 7.0 - 0.1 * t, "duration_s": 600 - t}})
    w.write("/events", 1.0, {"kind": "watchdog", "level": "fault", "message": "nav stale", "fields": {}})
    w.write(
        "/run/result",
        seconds,
        {"outcome": "succeeded", "duration_s": seconds, "failure_cause": None, "grasp": "holding", "metrics": {}},
    )
    if close:
        w.close()
    return w


@pytest.fixture()
def synthetic_log(tmp_path):
    path = tmp_path / "run.mcap"
    write_synthetic_log(path)
    return path


@pytest.fixture(scope="session")
def reference_log(tmp_path_factory):
    """The reference mission (seed 1, pool_fixed) run once with its log: (RunResult, log path)."""
    from pathlib import Path

    from mission.runtime.api import run_mission

    root = Path(__file__).resolve().parents[2]
    log = tmp_path_factory.mktemp("ref_log") / "reference.mcap"
    result = run_mission(
        RunTarget(root / "missions" / "maris_pipe_recovery.yaml", scenario="pool_fixed", seed=1),
        RunOptions(log_path=log),
    )
    return result, log
