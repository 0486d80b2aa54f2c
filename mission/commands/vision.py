"""``maris vision``: the stereo pipe detector on your own images.

* ``maris vision detect CALIB LEFT [RIGHT]``: run the detector on an image
  pair, two folders or two videos (or one side-by-side source without RIGHT);
  write an overlay PNG per pair (colour region, straight edges, fitted axis,
  grasp frame, confidence) and the poses as ``poses.csv`` / ``poses.json``.
* ``maris vision tune IMAGE [--roi x,y,w,h]``: HSV statistics inside the pipe's
  box and around it, thresholds that separate them, and mask previews of the
  current and suggested thresholds.
* ``maris vision calib CALIB [RIGHT]``: what a calibration file holds
  (sizes, focal lengths, fields of view, baseline, rectification).
* ``maris vision render OUT``: a stereo pair of the simulated pool with known
  truth and its calibration, to try the others on.

Bad input (missing files, a corrupt frame, mismatched sizes, a calibration of
the wrong shape) is reported in one line, never as a traceback; a pair without
the pipe is a detection with confidence 0 and the reason. Exit status: 0 when
every pair was read, 1 when some could not be, 2 for unusable arguments or files.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

from mission.commands._vision_tune import tune

# Imports inside the functions below are deliberate: shell completion (argcomplete) builds
# the parser on every Tab, so a command loads its heavy modules only when it runs.


def _floats(text: str, n: int, what: str) -> list[float]:
    try:
        vals = [float(x) for x in text.split(",")]
    except ValueError:
        raise argparse.ArgumentTypeError(f"{what}: expected {n} comma-separated numbers, got {text!r}") from None
    if len(vals) != n:
        raise argparse.ArgumentTypeError(f"{what}: expected {n} comma-separated numbers, got {len(vals)}")
    return vals


def register(subparsers: argparse._SubParsersAction) -> None:
    p = subparsers.add_parser(
        "vision",
        help="the stereo pipe detector on image pairs, folders or videos; HSV tuning",
        description=__doc__.split("\n\n")[1] if __doc__ else None,
    )
    sub = p.add_subparsers(dest="vision_command", metavar="VISION_COMMAND")

    d = sub.add_parser("detect", help="detect the pipe in image pairs; write overlays and poses")
    d.add_argument(
        "calibration", help="stereo calibration (OpenCV FileStorage YAML/JSON, or the left camera's ROS camera_info)"
    )
    d.add_argument(
        "left", help="left image, folder of images or video (or a side-by-side source when RIGHT is left out)"
    )
    d.add_argument("right", nargs="?", help="right image, folder or video")
    d.add_argument(
        "--calibration-right", metavar="FILE", help="right camera's ROS camera_info (or OpenCV extrinsics file)"
    )
    d.add_argument("--out", default="vision_out", help="output folder (default vision_out)")
    d.add_argument(
        "--attitude",
        metavar="ROLL,PITCH",
        help="vehicle roll,pitch (deg) for gravity, through the shipped URDF's camera "
        "mounting; default: the images' down direction",
    )
    d.add_argument("--hue", metavar="LO,HI", help="hue range, OpenCV 0-179 (default 22,35)")
    d.add_argument("--sat-min", type=int, help="minimum saturation 0-255 (default 63)")
    d.add_argument("--val-min", type=int, help="minimum value 0-255 (default 30)")
    d.add_argument("--radius", type=float, default=0.05, help="pipe radius, m (default 0.05)")
    d.add_argument("--length", type=float, default=1.0, help="pipe length, m (default 1.0)")
    d.add_argument(
        "--min-reported-confidence",
        type=float,
        default=0.2,
        help="answers less sure than this count as no pipe (default 0.2; 0: every answer)",
    )
    d.add_argument(
        "--frame",
        choices=("camera", "vehicle"),
        default="camera",
        help="frame of the CSV poses: left camera, or vehicle through the shipped URDF's camera mounting",
    )
    d.add_argument("--every", type=int, default=1, help="use every N-th pair (default 1)")
    d.add_argument("--max", type=int, help="stop after this many pairs")
    d.add_argument("--no-overlay", action="store_true", help="do not write overlay PNGs")
    d.set_defaults(func=run_detect)

    t = sub.add_parser("tune", help="HSV statistics and suggested thresholds for your pipe")
    t.add_argument("image", help="an image showing the pipe")
    t.add_argument(
        "--roi", metavar="X,Y,W,H", help="box around the pipe (px); default: the current thresholds' largest region"
    )
    t.add_argument("--hue", metavar="LO,HI", help="current hue range (default 22,35)")
    t.add_argument("--sat-min", type=int, default=63)
    t.add_argument("--val-min", type=int, default=30)
    t.add_argument("--out", default="vision_tune", help="folder for the mask previews (default vision_tune)")
    t.set_defaults(func=run_tune)

    c = sub.add_parser("calib", help="summarize a stereo calibration file")
    c.add_argument("calibration")
    c.add_argument("right", nargs="?", help="right camera's ROS camera_info (or OpenCV extrinsics file)")
    c.set_defaults(func=run_calib)

    r = sub.add_parser("render", help="render a simulated stereo pair with known truth (to try detect and tune)")
    r.add_argument("out", help="output folder: left.png, right.png, calibration.yaml, truth.json")
    r.add_argument("--range", type=float, default=1.25, help="m from the rig to the pipe's centre (default 1.25)")
    r.add_argument(
        "--elevation", type=float, default=55.0, help="deg of the line of sight above the floor (default 55)"
    )
    r.add_argument(
        "--azimuth",
        type=float,
        default=60.0,
        help="deg between the line of sight and the pipe axis, seen from above (default 60)",
    )
    r.add_argument("--turbidity", choices=("clear", "slightly_turbid", "very_turbid"), default="clear")
    r.add_argument("--size", metavar="W,H", default="646,482", help="image size, px (default 646,482)")
    r.add_argument("--seed", type=int, default=0)
    r.set_defaults(func=run_render)
    p.set_defaults(func=lambda args: (p.print_help(), 2)[1])


def _config(args: argparse.Namespace):  # noqa: ANN202
    from vision.detector import DetectorConfig
    from vision.silhouette import HsvRange

    base = HsvRange()
    hue = base.hue
    if getattr(args, "hue", None):
        lo, hi = (int(x) for x in _floats(args.hue, 2, "--hue"))
        hue = (lo, hi)
    sat = base.sat_min if getattr(args, "sat_min", None) is None else args.sat_min
    val = base.val_min if getattr(args, "val_min", None) is None else args.val_min
    return DetectorConfig(
        hsv=HsvRange(hue=hue, sat_min=sat, val_min=val),
        pipe_radius_m=args.radius,
        pipe_length_m=args.length,
        min_reported_confidence=getattr(args, "min_reported_confidence", DetectorConfig.min_reported_confidence),
    )


def run_detect(args: argparse.Namespace) -> int:
    import numpy as np

    from maris_common.yamlsrc import ConfigError
    from mission.commands._vision_io import SourceError, iter_pairs, pose_row, write_results
    from vision.calibration import load_stereo_calibration
    from vision.detector import calibration_for
    from vision.errors import VisionInputError
    from vision.overlay import draw_overlay
    from vision.pipeline import PipePoseEstimator

    try:
        calib = load_stereo_calibration(args.calibration, args.calibration_right)
        config = _config(args)
        errs = config.check()
        if errs:
            raise argparse.ArgumentTypeError("; ".join(errs))
        if args.every < 1:
            raise argparse.ArgumentTypeError("--every must be >= 1")
        attitude = None
        if args.attitude:
            r, p = _floats(args.attitude, 2, "--attitude")
            attitude = np.radians([r, p, 0.0])
    except ConfigError as exc:
        print(f"invalid calibration:\n{exc}", file=sys.stderr)
        return 2
    except argparse.ArgumentTypeError as exc:
        print(f"maris vision detect: {exc}", file=sys.stderr)
        return 2
    model = None
    if args.frame == "vehicle" or attitude is not None:  # the camera mounting (URDF) relates the vehicle to the camera
        from kcl.model import UvmsModel

        model = UvmsModel.load()
    est = PipePoseEstimator(calib, config, model)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    rows, records = [], []
    n = found = bad = 0
    costs = []
    try:
        for pair in iter_pairs(args.left, args.right, every=args.every, limit=args.max):
            n += 1
            if pair.error or pair.left is None or pair.right is None:
                bad += 1
                print(f"pair {pair.index} ({pair.name}): {pair.error or 'missing image'}", file=sys.stderr)
                continue
            try:
                det = est.estimate(pair.left, pair.right, attitude_rpy=attitude)
            except VisionInputError as exc:
                bad += 1
                print(f"pair {pair.index} ({pair.name}): {exc}", file=sys.stderr)
                continue
            costs.append(det.elapsed_ms)
            found += det.found
            rows.append(pose_row(pair, det, args.frame))
            records.append({"index": pair.index, "name": pair.name, **det.to_dict()})
            status = f"confidence {det.confidence:.2f}"
            T = det.cam_T_grasp
            if det.found and T is not None:
                status += f"  grasp origin ({T[0, 3]:+.3f}, {T[1, 3]:+.3f}, {T[2, 3]:+.3f}) m (camera)"
            if det.reason:
                status += f"  [{det.reason}]"
            print(f"pair {pair.index:5d} {pair.name}: {status}")
            if not args.no_overlay:
                import cv2

                h, w = pair.left.shape[:2]
                c = calibration_for(calib, w, h)
                region = _region(est, pair.left, pair.right, c)
                cv2.imwrite(str(out / f"overlay_{pair.index:06d}.png"), draw_overlay(pair.left, det, c, region))
    except SourceError as exc:
        print(f"maris vision detect: {exc}", file=sys.stderr)
        return 2
    csv_path, json_path = write_results(out, rows, records)
    med = f", median {np.median(costs):.1f} ms per pair" if costs else ""
    print(f"{n} pair(s): pipe found in {found}, not found in {len(rows) - found}, unreadable {bad}{med}")
    print(f"wrote {csv_path}, {json_path}" + ("" if args.no_overlay else f" and overlays in {out}/"))
    return 1 if bad else 0


def _region(est, left, right, calib):  # noqa: ANN001, ANN202 - the colour region drawn in overlays
    from vision.silhouette import select_region

    det = est.detector
    masks, _ = det.masks(left, right)
    region, _ = select_region(masks[0], max(12, int(det.config.min_area_fraction * left.shape[0] * left.shape[1])))
    return None if region is None else region.full()


def run_tune(args: argparse.Namespace) -> int:
    return tune(args)


def run_calib(args: argparse.Namespace) -> int:
    import numpy as np

    from maris_common.yamlsrc import ConfigError
    from vision.calibration import load_stereo_calibration
    from vision.rectify import rectify_calibration

    try:
        c = load_stereo_calibration(args.calibration, args.right)
    except ConfigError as exc:
        print(f"invalid calibration:\n{exc}", file=sys.stderr)
        return 2
    print(f"calibration {c.source}")
    for name, cam in (("left", c.left), ("right", c.right)):
        fh, fv = cam.fov
        print(
            f"  {name:5s} {cam.width}x{cam.height} px  fx {cam.K[0, 0]:.1f}  fy {cam.K[1, 1]:.1f}  centre ({cam.K[0, 2]:.1f}, {cam.K[1, 2]:.1f})"
            f"  fov {np.degrees(fh):.1f} x {np.degrees(fv):.1f} deg  distortion {np.round(cam.D, 4).tolist()}"
        )
    rot = np.degrees(np.arccos(np.clip((np.trace(c.R) - 1) / 2, -1, 1)))
    print(f"  baseline {c.baseline:.4f} m, right camera rotated {rot:.2f} deg, T = {np.round(c.T, 4).tolist()} m")
    try:
        r = rectify_calibration(c)
        print(
            f"  rectified: focal {r.focal_px:.1f} px, baseline {r.baseline:.4f} m; at 1.25 m a disparity of "
            f"{r.focal_px * r.baseline / 1.25:.1f} px"
        )
    except Exception as exc:  # noqa: BLE001 - report, do not crash
        print(f"  rectification failed: {exc}")
    return 0


def run_render(args: argparse.Namespace) -> int:
    import cv2
    import numpy as np

    from sim_backend.render_cases import default_calibration, view_case
    from vision.calibration import save_stereo_calibration

    try:
        w, h = (int(x) for x in _floats(args.size, 2, "--size"))
    except argparse.ArgumentTypeError as exc:
        print(f"maris vision render: {exc}", file=sys.stderr)
        return 2
    calib = default_calibration(w, h)
    case = view_case(
        args.range,
        elevation=np.radians(args.elevation),
        azimuth=np.radians(args.azimuth),
        turbidity=args.turbidity,
        calib=calib,
        seed=args.seed,
        aim_offset_m=0.25,
    )
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    cv2.imwrite(str(out / "left.png"), case.left)
    cv2.imwrite(str(out / "right.png"), case.right)
    save_stereo_calibration(calib, out / "calibration.yaml")
    truth = {
        "cam_T_grasp": case.cam_T_grasp.tolist(),
        "pipe_radius_m": 0.05,
        "pipe_length_m": 1.0,
        "range_m": case.range_m,
        "gravity_cam": case.gravity_cam.tolist(),
        "turbidity": args.turbidity,
    }
    (out / "truth.json").write_text(json.dumps(truth, indent=1))
    print(
        f"wrote {out}/left.png, right.png, calibration.yaml, truth.json (grasp frame {case.range_m:.2f} m away, {args.turbidity})"
    )
    print(f"try: maris vision detect {out}/calibration.yaml {out}/left.png {out}/right.png --out {out}/detect")
    return 0
