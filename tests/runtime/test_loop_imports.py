"""Nothing is imported inside the supervisor loop (the ``loop_imports`` metric).

A module imported lazily on the loop's path is read and executed in the middle
of a step the first time that path runs, which stalls that step (milliseconds,
more on a loaded machine: in real time, a missed deadline). Each run starts in a
new process: in this one, other tests have imported everything already and the
check could not fail.
"""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
REFERENCE = ROOT / "missions" / "maris_pipe_recovery.yaml"


@pytest.mark.slow
@pytest.mark.parametrize(
    "extra",
    [
        [],  # the reference mission with its log: tree, KCL, device and frame channels
        ["--inject", "dvl_dropout@15", "--inject", "joint_fault:2@25"],  # watchdog, drive fault, abort path
    ],
    ids=["reference", "faults_and_abort"],
)
def test_a_dry_run_imports_nothing_inside_its_loop(tmp_path, extra):
    proc = subprocess.run(
        [
            sys.executable,
            "-m",
            "mission.cli",
            "sim",
            str(REFERENCE),
            "--seed",
            "1",
            "--json",
            "--log",
            str(tmp_path / "run.mcap"),
            *extra,
        ],
        cwd=ROOT,
        capture_output=True,
        text=True,
        timeout=240,
    )
    doc = json.loads(proc.stdout)
    assert doc["metrics"]["loop_imports"] == [], doc["metrics"]["loop_imports"]
    if extra:  # the fault paths did run
        assert doc["outcome"] != "succeeded"


def test_a_vehicle_part_fault_is_classified_without_an_import():
    """The first FAULT of a vehicle part (a field-only path: the simulator's vehicle has no
    parts) is classified with what ``mission.runtime.safety`` imported already."""
    code = (
        "import sys\n"
        "from hal.interfaces import Health, HealthState\n"
        "from mission.runtime.safety import classify_health\n"
        "before = set(sys.modules)\n"
        "h = Health(HealthState.FAULT, 1.0, 'dvl lost', info={'dvl': {'state': 'fault', 'detail': 'no data'}})\n"
        "breaches = classify_health('vehicle', h)\n"
        "print([b.kind for b in breaches], sorted(set(sys.modules) - before))\n"
    )
    out = subprocess.run([sys.executable, "-c", code], cwd=ROOT, capture_output=True, text=True, timeout=60, check=True)
    assert out.stdout.strip() == "['sensor_lost'] []", out.stdout + out.stderr
