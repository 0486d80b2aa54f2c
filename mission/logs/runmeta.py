"""MCAP metadata records of a run log, and its time base.

Two metadata records (name -> string map) are written in every run log:

* ``maris.run`` at the start: mission name and path, scenario, seed, whether
  the clock is simulated, the wall-clock start (UTC), the HAL config, host, its
  CPU (:func:`cpu_description`: a replay elsewhere rounds differently) and the
  versions of the packages that decide the result;
* ``maris.result`` at the end: outcome, failure cause, duration (s), grasp.

Time base (:func:`time_base`): a simulator run keeps simulated time (log times
start near 0, 1970-01-01 in a viewer; ``time_base=simulated``); a field run is
stamped with the wall clock (``time_base=wall_clock``): log time = backend
clock + an offset fixed at the start, so the monotonic backend clock keeps the
messages ordered even if the system clock is stepped during the run.
"""

from __future__ import annotations

import datetime as _dt
import platform
import sys
import time
from importlib import metadata as _md
from typing import Any

#: Packages whose versions are recorded (distribution names).
VERSIONED = ("maris-uvms", "numpy", "pin", "py_trees", "mcap", "foxglove-sdk", "numba", "scipy")


def versions() -> dict[str, str]:
    """``{distribution: version}`` of :data:`VERSIONED` plus Python (missing ones skipped)."""
    out = {"python": platform.python_version()}
    for name in VERSIONED:
        try:
            out[name] = _md.version(name)
        except _md.PackageNotFoundError:
            continue
    return out


#: CPU flags that decide which vector kernels numpy, OpenBLAS and Numba use (so how results round).
_SIMD_FLAGS = ("avx512f", "avx2", "fma", "asimd", "sve")


def cpu_description() -> str:
    """The CPU this process runs on, as the run log records it: model name, machine
    and the vector-instruction flags of :data:`_SIMD_FLAGS` it has, e.g.
    ``"AMD EPYC (x86_64; avx512f avx2 fma)"``. Two machines with different ones may
    round the last bit of numpy's, OpenBLAS's and Numba's results differently."""
    model, flags = "", set[str]()
    try:
        with open("/proc/cpuinfo", encoding="utf-8", errors="replace") as fh:
            for line in fh:
                key, _, value = line.partition(":")
                key = key.strip().lower()
                if key in ("model name", "cpu model", "hardware") and not model:
                    model = value.strip()
                elif key in ("flags", "features") and not flags:
                    flags = set(value.split())
                if model and flags:
                    break
    except OSError:
        pass
    model = model or platform.processor() or "unknown CPU"
    simd = " ".join(f for f in _SIMD_FLAGS if f in flags)
    return f"{model} ({platform.machine()}{'; ' + simd if simd else ''})"


def time_base(simulated: bool, clock_now_s: float) -> tuple[int, dict[str, str]]:
    """``(offset_ns, metadata)``: the offset to add to backend-clock ns for log
    times, and how to read them."""
    wall_ns = time.time_ns()
    start_utc = _dt.datetime.fromtimestamp(wall_ns / 1e9, _dt.UTC).isoformat(timespec="milliseconds")
    if simulated:
        return 0, {
            "time_base": "simulated",
            "time_note": "log times are simulated seconds from 0 (the viewer shows "
            "1970-01-01); wall_start_utc says when the run was made",
            "wall_start_utc": start_utc,
        }
    offset = wall_ns - int(round(clock_now_s * 1e9))
    return offset, {
        "time_base": "wall_clock",
        "time_note": "log time = backend clock + time_offset_ns (UTC ns)",
        "time_offset_ns": str(offset),
        "wall_start_utc": start_utc,
    }


def run_metadata(
    *,
    mission_name: str,
    mission_path: str,
    scenario: str | None,
    seed: int | None,
    hal_config: str | None,
    time_meta: dict[str, str],
    input_record: bool = True,
) -> dict[str, Any]:
    """The ``maris.run`` record (``input_record``: whether the log holds the input record
    that ``maris log replay`` needs; ``"no"`` lets the replay say why it has none)."""
    meta: dict[str, Any] = {
        "mission": mission_name,
        "mission_path": mission_path,
        "input_record": "yes" if input_record else "no",
        "scenario": scenario or "",
        "seed": "" if seed is None else str(seed),
        "backend": "simulator" if scenario is not None else "hardware",
        "hal_config": hal_config or "",
        "host": platform.node(),
        "cpu": cpu_description(),
        "argv": " ".join(sys.argv),
        **time_meta,
    }
    meta.update({f"version.{k}": v for k, v in versions().items()})
    return meta


def result_metadata(result: Any) -> dict[str, str]:
    """The ``maris.result`` record from a :class:`mission.runtime.result.RunResult`."""
    return {
        "outcome": str(result.outcome),
        "failure_cause": result.failure_cause or "",
        "duration_s": f"{result.duration_s:.3f}",
        "grasp": result.grasp or "",
    }
