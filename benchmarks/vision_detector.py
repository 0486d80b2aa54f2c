"""Cost of the stereo pipe detector per image pair, and of rendering a pair.

Measures, on ONE core (OpenCV and BLAS limited to one thread), the median and
90th percentile time of ``PipeDetector.detect`` on rendered pairs with the pipe
in view (0.8-2.5 m, varied viewing angles, clear water), at the full MARIS
resolution (1292 x 964) and at the simulator's rendered resolution (646 x 482),
plus the simulator's cost to render one pair at that resolution. Target: <= 50
ms per pair at full resolution. Figures are wall times of this process; on a
shared machine they include waiting for the core (cpu times are printed too).

    .venv/bin/python benchmarks/vision_detector.py [--pairs 24]
"""

from __future__ import annotations

import os

for _v in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS", "NUMBA_NUM_THREADS"):
    os.environ.setdefault(_v, "1")

import argparse  # noqa: E402
import json  # noqa: E402
import time  # noqa: E402

import numpy as np  # noqa: E402


def _views(n: int) -> list[tuple[float, float, float, float]]:
    rng = np.random.default_rng(7)
    return [
        (
            float(rng.uniform(0.8, 2.5)),
            float(rng.uniform(0.6, 1.25)),
            float(rng.uniform(0.9, 2.2)),
            float(rng.uniform(-0.3, 0.3)),
        )
        for _ in range(n)
    ]


def bench(width: int, height: int, n: int) -> dict:
    import cv2

    from sim_backend.render import StereoRenderer
    from sim_backend.render_cases import default_calibration, view_case, visibility
    from sim_backend.render_optics import WaterOptics
    from vision.detector import PipeDetector

    cv2.setNumThreads(1)
    calib = default_calibration(width, height)
    rend = StereoRenderer(calib, WaterOptics.for_visibility(visibility("clear")), np.random.default_rng(1))
    det = PipeDetector(calib)
    cases, render_ms = [], []
    for rng, el, az, off in _views(n):
        t0 = time.perf_counter()
        cases.append(view_case(rng, elevation=el, azimuth=az, aim_offset_m=off, calib=calib, renderer=rend))
        render_ms.append(1e3 * (time.perf_counter() - t0))
    det.detect(cases[0].left, cases[0].right, gravity_cam=cases[0].gravity_cam)  # warm up
    wall, cpu, found = [], [], 0
    for c in cases:
        t0, c0 = time.perf_counter(), time.process_time()
        d = det.detect(c.left, c.right, gravity_cam=c.gravity_cam)
        wall.append(1e3 * (time.perf_counter() - t0))
        cpu.append(1e3 * (time.process_time() - c0))
        found += d.found
    return {
        "size": f"{width}x{height}",
        "pairs": n,
        "found": found,
        "median_ms": float(np.median(wall)),
        "p90_ms": float(np.percentile(wall, 90)),
        "median_cpu_ms": float(np.median(cpu)),
        "render_median_ms": float(np.median(render_ms)),
    }


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--pairs", type=int, default=24)
    args = ap.parse_args()
    out = {}
    for w, h in ((1292, 964), (646, 482)):
        r = bench(w, h, args.pairs)
        out[r["size"]] = r
        print(
            f"detector {r['size']:>9}: median {r['median_ms']:6.1f} ms  p90 {r['p90_ms']:6.1f} ms  (cpu median {r['median_cpu_ms']:6.1f} ms) "
            f"per pair, one core, pipe found in {r['found']}/{r['pairs']}"
        )
    print(
        f"render    646x482: median {out['646x482']['render_median_ms']:6.1f} ms per stereo pair (simulator, one core)"
    )
    full = out["1292x964"]["median_ms"]
    print(f"target <= 50 ms per pair at 1292x964: {'met' if full <= 50.0 else 'NOT met'} ({full:.1f} ms)")
    print(
        "vision_detector "
        + json.dumps(
            {
                "full_ms": round(full, 1),
                "rendered_ms": round(out["646x482"]["median_ms"], 1),
                "render_pair_ms": round(out["646x482"]["render_median_ms"], 1),
            }
        )
    )


if __name__ == "__main__":
    main()
