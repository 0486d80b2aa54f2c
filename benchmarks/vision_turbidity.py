"""Detection rate of the rendered MARIS pipe detector versus water visibility and range.

For each water visibility (the rendered model's ``vision.water_visibility_m``:
horizontal visibility of a dark target, beam attenuation 4.8 / V) and each
range from the rig to the pipe's grasp point, renders ``--views`` pairs at
varied viewing angles (as ``benchmarks/vision_accuracy.py``: elevation 35-70
deg, azimuth 35-90 deg to the pipe axis, aim point along the pipe, caustic
phase) and counts the pairs detected at the reference mission's threshold
(confidence >= 0.7, the mission's threshold). The table model's per-turbidity detection probability and
range for a given water (e.g. ``pool_oct2015``) are read off this table.

    .venv/bin/python benchmarks/vision_turbidity.py [--visibility 3.5,4,4.5,5] [--ranges 0.6,0.8,1.0,1.2] [--views 16]

Last line: ``vision_turbidity {json}`` (visibility -> range -> rate).
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

from vision_accuracy import THRESHOLD, run_cell  # noqa: E402


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--visibility", default="3.5,4,4.5,5", help="water visibilities (m), comma-separated")
    ap.add_argument("--ranges", default="0.6,0.7,0.8,0.9,1.0,1.1,1.2", help="ranges (m), comma-separated")
    ap.add_argument("--views", type=int, default=16, help="rendered pairs per cell")
    args = ap.parse_args()

    from sim_backend.render import StereoRenderer
    from sim_backend.render_cases import default_calibration
    from sim_backend.render_optics import WaterOptics
    from vision.detector import PipeDetector

    calib = default_calibration(646, 482)
    det = PipeDetector(calib)
    ranges = [float(x) for x in args.ranges.split(",")]
    print(f"rendered detector, 646x482, {args.views} views per cell, detected = confidence >= {THRESHOLD}")
    print("visibility m | " + " | ".join(f"{r:g} m" for r in ranges))
    table: dict[str, dict[str, float]] = {}
    for vis in (float(x) for x in args.visibility.split(",")):
        rend = StereoRenderer(calib, WaterOptics.for_visibility(vis), np.random.default_rng(11))
        row = {}
        for r in ranges:
            recs = run_cell(calib, rend, det, r, args.views, seed=int(100 * r))
            row[f"{r:g}"] = float(np.mean([x["confidence"] >= THRESHOLD and "pos_cm" in x for x in recs]))
        table[f"{vis:g}"] = row
        print(f"{vis:g} | " + " | ".join(f"{100 * row[f'{r:g}']:.0f} %" for r in ranges), flush=True)
    print("vision_turbidity " + json.dumps(table))


if __name__ == "__main__":
    main()
