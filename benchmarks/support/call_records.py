"""Shared parts of the record/replay benchmarks (``kcl_calls.py``, ``sim_calls.py``):
the largest difference between a recorded and a replayed result, and
counting the instructions of a replay under valgrind's callgrind.

A counting script re-runs itself under ``valgrind --tool=callgrind
--instr-atstart=no`` with an environment marker set (the child); the child
switches the instrumentation on around the part to count (:func:`instrument`)
and the parent reads the total from callgrind's ``Collected`` line
(:func:`run_counted`).
"""

from __future__ import annotations

import os
import re
import subprocess
import sys
import tempfile
from pathlib import Path
from typing import Any

import numpy as np


def largest_difference(a: Any, b: Any) -> float:
    """Largest absolute difference between two results (dataclasses, dicts,
    sequences, arrays, floats; NaN equals NaN); inf on a structural mismatch."""
    if hasattr(a, "__dataclass_fields__"):
        if type(a) is not type(b):
            return float("inf")
        return largest_difference(vars(a), vars(b))
    if isinstance(a, dict):
        if not isinstance(b, dict) or a.keys() != b.keys():
            return float("inf")
        return max([largest_difference(a[k], b[k]) for k in a], default=0.0)
    if isinstance(a, (tuple, list)):
        if not isinstance(b, (tuple, list)) or len(a) != len(b):
            return float("inf")
        return max([largest_difference(x, y) for x, y in zip(a, b)], default=0.0)
    if isinstance(a, (np.ndarray, float)):
        if not isinstance(b, (np.ndarray, float)):
            return float("inf")
        a_arr, b_arr = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
        if a_arr.shape != b_arr.shape:
            return float("inf")
        same = (a_arr == b_arr) | (np.isnan(a_arr) & np.isnan(b_arr))
        if same.all():
            return 0.0
        return float(np.max(np.abs(a_arr - b_arr)[~same]))
    return 0.0 if a == b else float("inf")


def instrument(flag: str) -> None:
    """Switch callgrind's instrumentation of this process ``"on"`` or ``"off"``."""
    subprocess.run(["callgrind_control", "-i", flag, str(os.getpid())], check=True, capture_output=True)


def run_counted(script: str, args: list[str], child_marker: str, keep_out_env: str) -> int | None:
    """Run ``script args`` under callgrind with ``child_marker`` set in its
    environment; return the instructions it collected (those between its
    ``instrument("on")`` and ``instrument("off")``), or None after printing the
    child's output tails to stderr. ``keep_out_env`` names an environment
    variable that, when set, is the file to keep callgrind's profile in."""
    with tempfile.TemporaryDirectory() as tmp:
        cg_out = Path(os.environ.get(keep_out_env, Path(tmp) / "callgrind.out"))
        cmd = [
            "valgrind",
            "--tool=callgrind",
            "--instr-atstart=no",
            f"--callgrind-out-file={cg_out}",
            sys.executable,
            script,
            *args,
        ]
        proc = subprocess.run(cmd, env={**os.environ, child_marker: "1"}, capture_output=True, text=True)
    found = re.search(r"Collected\s*:\s*(\d+)", proc.stderr)
    if proc.returncode != 0 or not found:
        print(proc.stdout[-2000:], proc.stderr[-4000:], sep="\n", file=sys.stderr)
        return None
    return int(found.group(1))


def command_parsers(description: str) -> tuple[Any, Any]:
    """The command line both scripts start from: ``(parser, subparsers)`` with
    ``record OUT [--scenario] [--seed]`` already there."""
    import argparse

    ap = argparse.ArgumentParser(description=description)
    sub = ap.add_subparsers(dest="cmd", required=True)
    r = sub.add_parser("record")
    r.add_argument("out", type=Path)
    r.add_argument("--scenario", default="pool_fixed")
    r.add_argument("--seed", type=int, default=1)
    return ap, sub
