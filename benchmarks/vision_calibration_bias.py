"""The table model's stereo calibration bias against the rendered detector's.

For ``--draws`` calibration errors drawn as the scenarios draw them
(``sim_backend.vision_calibration.StereoBias.draw`` with pool_clear's default
standard deviations) and ``--views`` rendered pairs per range (1, 1.5, 2 m;
varied viewing angles, clear water, 646 x 482), compares two figures per pair:

* rendered: how far the real detector's grasp point moves when it works with
  the believed (wrong) calibration instead of the exact one;
* table: how far the table model's triangulation (:meth:`StereoBias.apparent_pose`)
  moves the true grasp point with the same calibration error.

Prints the median and 90th percentile per range (mm). Last line:
``vision_calibration_bias {json}``.

    .venv/bin/python benchmarks/vision_calibration_bias.py [--draws 8] [--views 4]
"""

from __future__ import annotations

import argparse
import json

import numpy as np

RANGES = (1.0, 1.5, 2.0)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--draws", type=int, default=8, help="calibration errors drawn")
    ap.add_argument("--views", type=int, default=4, help="rendered pairs per range and draw")
    args = ap.parse_args()

    from sim_backend.render import StereoRenderer
    from sim_backend.render_cases import default_calibration, view_case
    from sim_backend.render_optics import WaterOptics
    from sim_backend.schema import PARAMS_BY_KEY
    from sim_backend.vision_calibration import StereoBias
    from vision.detector import PipeDetector

    params = {k: p.default for k, p in PARAMS_BY_KEY.items()}
    calib = default_calibration(646, 482)
    renderer = StereoRenderer(calib, WaterOptics.for_visibility(20.0), np.random.default_rng(12))
    exact = PipeDetector(calib)
    rows = []
    for draw in range(args.draws):
        bias = StereoBias.draw(calib, params, np.random.default_rng(1000 + draw))
        det = PipeDetector(bias.believed)
        rng = np.random.default_rng(draw)
        for r in RANGES:
            for _ in range(args.views):
                el, az = rng.uniform(np.radians(35), np.radians(70)), rng.uniform(np.radians(35), np.radians(90))
                c = view_case(
                    r,
                    elevation=el,
                    azimuth=az,
                    aim_offset_m=rng.uniform(-0.3, 0.3),
                    calib=calib,
                    renderer=renderer,
                    t=float(rng.uniform(0, 30)),
                )
                d = det.detect(c.left, c.right, gravity_cam=c.gravity_cam, vehicle_T_camera=c.vehicle_T_camera)
                d0 = exact.detect(c.left, c.right, gravity_cam=c.gravity_cam, vehicle_T_camera=c.vehicle_T_camera)
                if d.confidence < 0.6 or d.cam_T_grasp is None or d0.cam_T_grasp is None:
                    continue
                rendered = float(np.linalg.norm(d.cam_T_grasp[:3, 3] - d0.cam_T_grasp[:3, 3]))
                table = float(np.linalg.norm(bias.apparent_pose(c.cam_T_grasp)[:3, 3] - c.cam_T_grasp[:3, 3]))
                rows.append((r, rendered, table))
    R = np.array(rows)
    out = {}
    print(f"calibration bias of the grasp point, {args.draws} draws x {args.views} views per range (mm)")
    print("range | pairs | rendered detector median / p90 | table model median / p90")
    for r in RANGES:
        m = R[:, 0] == r
        f = {
            k: float(1000 * np.percentile(R[m, i], q))
            for k, i, q in (
                ("rendered_med", 1, 50),
                ("rendered_p90", 1, 90),
                ("table_med", 2, 50),
                ("table_p90", 2, 90),
            )
        }
        out[f"{r:g}"] = {"pairs": int(m.sum()), **{k: round(v, 1) for k, v in f.items()}}
        print(
            f"{r:g} m | {int(m.sum())} | {f['rendered_med']:.1f} / {f['rendered_p90']:.1f} | {f['table_med']:.1f} / {f['table_p90']:.1f}"
        )
    print("vision_calibration_bias " + json.dumps(out))


if __name__ == "__main__":
    main()
