"""The pipe detector on an evaluation set it was not tuned on, beside a simple baseline.

The set comes from :mod:`sim_backend.evalset`: stereo pairs at the Mako's full
resolution (1292 x 964) made by an image formation of its own (not the
simulator's renderer the detector was developed on): a procedural pool floor,
daylight with shadows, lamps with backscatter, colour casts, Bayer sensor
noise, JPEG compression and motion blur, each drawn independently; clear,
slightly turbid and very turbid water; 0.9-2.5 m; the arm hiding part of the
pipe; the pipe partly out of view; pipe-free views. The detector gets the rig
as ROS ``camera_info`` files, gravity from the attitude, the arm mask where
the arm is in view (its silhouette dilated by 4 px and shifted up to 2 px).

Per condition it prints: detection rate (a pair is detected when the
detector's confidence reaches ``--threshold``, by default the reference
mission's ``detection_threshold``), the median and 95th percentile axis error
(deg) and pipe-end error (cm, over detections that report an end), wrong
detections (axis > 5 deg or the axis more than 5 cm from the true one) and
false positives on pipe-free views (at the threshold, and at any confidence
reported: a confidence > 0); the baseline (HSV + one straight line per
image, ``benchmarks/support/hsv_line_baseline.py``) beside it; the detector's
time per pair on one core (OpenCV and BLAS limited to one thread): wall time
in ``--timing-passes`` passes over the pairs (3 by default; the first with the
baseline and the monocular detector run between the pairs, the others the
detector alone), each pass's median and the median of those, and CPU time in
the first pass. Then the monocular mode (left image only) and the
error-versus-confidence curve (all pipe views the detector answered, with the
answers under its least reported confidence, which it reports as no pipe, at the
confidence they had). 'found' in the tables is likewise any answer that is right,
reported or not.

    .venv/bin/python benchmarks/vision_evalset.py [--split eval|tune|tune2] [--scale 1.0] [--cache DIR] [--json out.json]
        [--jpeg-quality Q]

A last table gives the detection rate in very turbid water within 1.3 m per
image draw (visibility, lamps, JPEG, motion blur, gain, floor); the set draws
them independently. Another gives it per bin of the pipe's contrast against the
floor beside it in the left image (``sim_backend.evalset.pipe_contrast``: the colour
difference and its part without grey, 8-bit levels), over every water and over very
turbid water within 1.3 m: the detector's detection limit in terms of the image alone.
``--pooled A.json B.json ...`` prints these two tables over the ``--json`` outputs of
several splits (38 very turbid views within 1.3 m a split are few).

``--jpeg-quality Q`` encodes every image again as JPEG at quality Q before the
detector sees it (the set's own images carry JPEG at quality 55-95, or none):
what a compressed camera stream does to the detection.

``--split tune`` and ``--split tune2`` are the development splits (the same
plan of conditions, other seeds): tune on them, never on ``eval``. Rendering the set takes a few seconds per pair the first time; the
pairs are cached (``--cache``, default a folder in the temp directory).
"""

from __future__ import annotations

import os

for _v in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS", "NUMBA_NUM_THREADS"):
    os.environ.setdefault(_v, "1")

import argparse  # noqa: E402
import json  # noqa: E402
import math  # noqa: E402
import tempfile  # noqa: E402
import time  # noqa: E402
from dataclasses import asdict, dataclass  # noqa: E402
from pathlib import Path  # noqa: E402
from typing import Any  # noqa: E402

import numpy as np  # noqa: E402

REPO = Path(__file__).resolve().parents[1]
MISSION = REPO / "missions" / "maris_pipe_recovery.yaml"
WRONG_AXIS_DEG = 5.0
WRONG_OFFSET_M = 0.05
CONDITIONS = ("clear", "slightly_turbid", "very_turbid")


@dataclass(frozen=True)
class DrawBin:
    """One bin of an image draw in the table by image condition: ``lo <= value < hi``, or for a
    category (``lo`` a string) the value itself."""

    label: str
    lo: float | str
    hi: float = math.inf

    def holds(self, value: Any) -> bool:
        if isinstance(self.lo, str):
            return bool(value == self.lo)
        return value is not None and self.lo <= float(value) < self.hi


#: The table by image condition: per draw (name, ``View.params`` key), its bins. Visibility spans
#: the very turbid water's 1.2-2.0 m; a JPEG quality of 0 is no JPEG.
DRAW_BINS: tuple[tuple[str, str, tuple[DrawBin, ...]], ...] = (
    (
        "visibility",
        "visibility_m",
        (DrawBin("1.2-1.4 m", 0.0, 1.4), DrawBin("1.4-1.7 m", 1.4, 1.7), DrawBin("1.7-2.0 m", 1.7)),
    ),
    ("lamps", "lamp_power", (DrawBin("off", 0.0, 1e-9), DrawBin("on", 1e-9))),
    ("JPEG", "jpeg_quality", (DrawBin("none", 0, 1), DrawBin("quality 55-80", 1, 81), DrawBin("quality 81-95", 81))),
    ("motion blur", "motion_px", (DrawBin("< 1 px", 0.0, 1.0), DrawBin(">= 1 px", 1.0))),
    ("analog gain", "gain", (DrawBin("< 8", 0.0, 8.0), DrawBin(">= 8", 8.0))),
    ("floor", "floor", (DrawBin("tiles", "tiles"), DrawBin("concrete", "concrete"), DrawBin("painted", "painted"))),
)
#: The image draws kept in each record for that table.
IMAGE_DRAWS = tuple(key for _, key, _ in DRAW_BINS)


def doubling_bins(edges: tuple[float, ...]) -> tuple[DrawBin, ...]:
    """Bins under the first edge, between consecutive edges and from the last one on."""
    inner = tuple(DrawBin(f"{a:g}-{b:g}", a, b) for a, b in zip(edges[:-1], edges[1:]))
    return (DrawBin(f"< {edges[0]:g}", 0.0, edges[0]), *inner, DrawBin(f">= {edges[-1]:g}", edges[-1]))


#: The table by the pipe's contrast (``sim_backend.evalset.PipeContrast``, 8-bit levels): its
#: colour difference from the floor beside it, and that difference without its grey part.
CONTRAST_BINS: tuple[tuple[str, str, tuple[DrawBin, ...]], ...] = (
    ("colour", "colour", doubling_bins((2.0, 4.0, 8.0, 16.0))),
    ("chroma", "chroma", doubling_bins((1.0, 2.0, 4.0, 8.0))),
)


def mission_threshold() -> float:
    """The reference mission's detection threshold (``detection_threshold``)."""
    import yaml

    doc = yaml.safe_load(MISSION.read_text())
    found: list[float] = []

    def walk(x: Any) -> None:
        if isinstance(x, dict):
            for k, v in x.items():
                if k in ("detection_threshold", "min_confidence") and isinstance(v, (int, float)):
                    found.append(float(v))
                walk(v)
        elif isinstance(x, list):
            for v in x:
                walk(v)

    walk(doc)
    return found[0] if found else 0.6


def axis_error_deg(a: np.ndarray, b: np.ndarray) -> float:
    cosine = abs(float(a @ b)) / float(np.linalg.norm(a) * np.linalg.norm(b))
    return float(np.degrees(np.arccos(min(1.0, cosine))))


def line_offset(p: np.ndarray, a: np.ndarray, q: np.ndarray) -> float:
    """Distance (m) of point q from the line p + s a."""
    a = a / np.linalg.norm(a)
    d = q - p
    return float(np.linalg.norm(d - (d @ a) * a))


def score(view: Any, axis_p: np.ndarray | None, axis_a: np.ndarray | None, end: np.ndarray | None) -> dict:
    """Errors of one answer against the view's truth."""
    rec: dict = {}
    if view.cam_T_pipe is None or axis_p is None or axis_a is None:
        return rec
    T = view.cam_T_pipe
    rec["axis_deg"] = axis_error_deg(axis_a, T[:3, 0])
    rec["offset_m"] = line_offset(axis_p, axis_a, T[:3, 3])
    rec["wrong"] = rec["axis_deg"] > WRONG_AXIS_DEG or rec["offset_m"] > WRONG_OFFSET_M
    if end is not None:
        rec["end_m"] = float(np.min(np.linalg.norm(view.ends_cam - end[None, :], axis=1)))
    return rec


def run(args: argparse.Namespace) -> dict:
    import cv2

    from sim_backend.evalset import eval_rig, load_view, pipe_contrast, views, write_rig_files
    from vision.calibration import load_stereo_calibration
    from vision.detector import PipeDetector

    cv2.setNumThreads(1)
    cache = Path(args.cache) if args.cache else Path(tempfile.gettempdir()) / f"maris-evalset-{args.split}"
    paths = views(args.split, args.scale, cache, progress=True)
    left_file, right_file = write_rig_files(eval_rig(), cache / "calibration")
    calib = load_stereo_calibration(left_file, right_file)
    det = PipeDetector(calib)
    mono = _mono_detector(calib)
    sys_path_support()
    from support.hsv_line_baseline import detect as baseline

    def load(path: Path) -> Any:
        v = load_view(path)
        if args.jpeg_quality:  # compressed again, as a camera stream the vehicle encodes would be
            v.left, v.right = (jpeg_again(im, args.jpeg_quality) for im in (v.left, v.right))
        return v

    records = []
    first = True
    for path in paths:
        v = load(path)
        if first:  # warm-up: imports and caches out of the timing
            det.detect(v.left, v.right, gravity_cam=v.gravity_cam)
            first = False
        t0, c0 = time.perf_counter(), time.process_time()
        d = det.detect(v.left, v.right, gravity_cam=v.gravity_cam, arm_masks=v.arm_masks)
        wall, cpu = 1e3 * (time.perf_counter() - t0), 1e3 * (time.process_time() - c0)
        contrast = pipe_contrast(v)  # of the image the detector got (after any re-encoding)
        rec: dict[str, Any] = {
            "name": v.name,
            "kind": v.kind,
            "water": v.water_name,
            "range_m": v.range_m,
            "ends_visible": list(v.ends_visible),
            "confidence": float(d.confidence),
            "wall_ms": wall,
            "cpu_ms": cpu,
            "reason": d.reason,
            "views_used": d.quality.get("views_used"),
            "quality": {k: v for k, v in d.quality.items() if k != "factors"},
            "image": {k: v.params.get(k) for k in IMAGE_DRAWS},
            "pipe_contrast": None if contrast is None else asdict(contrast),
        }
        rec.update(score(v, d.axis_point_cam, d.axis_dir_cam, d.end_cam))
        grasp = answer_grasp(d)
        if grasp is not None and v.cam_T_pipe is not None and d.end_cam is not None:
            rec["grasp_m"] = float(np.linalg.norm(grasp[:3, 3] - v.cam_T_pipe[:3, 3]))
        b = baseline(v.left, v.right, calib)
        rec["baseline"] = {"found": b is not None}
        if b is not None:
            rec["baseline"].update(score(v, b.point, b.direction, b.end))
        if mono is not None:
            m = mono(v)
            rec["mono"] = {
                "confidence": float(m.confidence),
                "quality": {"confidence_unreported": m.quality.get("confidence_unreported", 0.0)},
            }
            rec["mono"].update(score(v, m.axis_point_cam, m.axis_dir_cam, m.end_cam))
            mono_grasp = answer_grasp(m)
            if mono_grasp is not None and v.cam_T_pipe is not None and m.end_cam is not None:
                rec["mono"]["grasp_m"] = float(np.linalg.norm(mono_grasp[:3, 3] - v.cam_T_pipe[:3, 3]))
        records.append(rec)
    passes = [[r["wall_ms"] for r in records]]
    for k in range(1, args.timing_passes):  # the same pairs again: the host's speed moves between passes
        print(f"timing pass {k + 1} of {args.timing_passes}...", flush=True)
        walls = []
        for path in paths:
            v = load(path)
            t0 = time.perf_counter()
            det.detect(v.left, v.right, gravity_cam=v.gravity_cam, arm_masks=v.arm_masks)
            walls.append(1e3 * (time.perf_counter() - t0))
        passes.append(walls)
    return {
        "records": records,
        "timing_passes_ms": passes,
        "threshold": args.threshold,
        "split": args.split,
        "scale": args.scale,
        "jpeg_quality": args.jpeg_quality,
    }


def jpeg_again(bgr: np.ndarray, quality: int) -> np.ndarray:
    """``bgr`` JPEG-encoded at ``quality`` (OpenCV's encoder: 4:2:0 chroma) and decoded."""
    import cv2

    ok, buf = cv2.imencode(".jpg", bgr, [cv2.IMWRITE_JPEG_QUALITY, int(quality)])
    if not ok:
        raise RuntimeError("JPEG encoding failed")
    return cv2.imdecode(buf, cv2.IMREAD_COLOR)


def answer_grasp(d: Any) -> np.ndarray | None:
    """The grasp frame of a detection's answer, reported or not (see :func:`answer_confidence`)."""
    if d.cam_T_grasp is not None:
        return np.asarray(d.cam_T_grasp)
    unreported = d.quality.get("cam_T_grasp_unreported")
    return None if unreported is None else np.asarray(unreported)


def _mono_detector(calib: Any) -> Any:
    """The monocular detector on the left image, or None when the package has none."""
    try:
        from vision.monocular import MonocularPipeDetector
    except ImportError:
        return None
    mono = MonocularPipeDetector(calib.left)
    return lambda v: mono.detect(
        v.left, gravity_cam=v.gravity_cam, arm_mask=None if v.arm_masks is None else v.arm_masks[0]
    )


def sys_path_support() -> None:
    import sys

    here = str(Path(__file__).resolve().parent)
    if here not in sys.path:
        sys.path.insert(0, here)


# ----------------------------------------------------------------------------- tables


def pct(x: list[float], q: float) -> float:
    return float(np.percentile(x, q)) if x else float("nan")


def cell(recs: list[dict], thr: float, key: str | None = None) -> dict:
    """Summary of one condition for the detector (key None), 'baseline' or 'mono'."""

    def get(r: dict) -> dict:
        return r if key is None else r.get(key, {})

    def detected(r: dict) -> bool:
        g = get(r)
        if key == "baseline":
            return bool(g.get("found"))
        return g.get("confidence", 0.0) >= thr

    def found(r: dict) -> bool:
        g = get(r)
        return bool(g.get("found")) if key == "baseline" else answer_confidence(g) > 0.0

    def reported(r: dict) -> bool:
        """Any answer given as the pipe (the detector's confidence > 0; every baseline answer)."""
        g = get(r)
        return bool(g.get("found")) if key == "baseline" else g.get("confidence", 0.0) > 0.0

    pipe = [r for r in recs if r["kind"] != "nopipe"]
    free = [r for r in recs if r["kind"] == "nopipe"]
    hits = [get(r) for r in pipe if detected(r)]
    any_hits = [get(r) for r in pipe if found(r)]
    good = [h for h in hits if not h.get("wrong", True)]
    axis = [h["axis_deg"] for h in hits if "axis_deg" in h]
    end = [100 * h["end_m"] for h in hits if "end_m" in h]
    grasp = [100 * h["grasp_m"] for h in hits if "grasp_m" in h]
    return {
        "pipe_views": len(pipe),
        "found_correct": sum(1 for h in any_hits if not h.get("wrong", True)),
        "detected": len(hits),
        "rate": len(hits) / len(pipe) if pipe else float("nan"),
        "correct": len(good),
        "wrong": len(hits) - len(good),
        "axis_med": pct(axis, 50),
        "axis_p95": pct(axis, 95),
        "end_med_cm": pct(end, 50),
        "end_p95_cm": pct(end, 95),
        "ends": len(end),
        "grasp_med_cm": pct(grasp, 50),
        "free_views": len(free),
        "false_pos": sum(1 for r in free if detected(r)),
        "reported_free": sum(1 for r in free if reported(r)),
    }


def fmt_cell(c: dict) -> str:
    if c["pipe_views"] == 0:
        return f"{'-':>18s}"
    s = f"{100 * c['rate']:5.1f} % ({c['detected']:3d}/{c['pipe_views']:3d}) found {100 * c['found_correct'] / c['pipe_views']:5.1f} %"
    s += f"  axis {c['axis_med']:5.2f}/{c['axis_p95']:5.2f} deg  end {c['end_med_cm']:5.2f}/{c['end_p95_cm']:5.2f} cm"
    s += f"  wrong {c['wrong']:2d}"
    return s


def print_tables(res: dict) -> dict:
    recs, thr = res["records"], res["threshold"]
    out: dict = {"threshold": thr, "conditions": {}}
    again = f", every image JPEG-encoded again at quality {res['jpeg_quality']}" if res.get("jpeg_quality") else ""
    print(
        f"\nevaluation set '{res['split']}' ({len(recs)} pairs, 1292x964{again}), detected = confidence >= {thr:g};"
        " ('found' = any answer and right, reported or not); errors median/p95 over detections; wrong = axis > 5 deg or > 5 cm off"
    )
    # every condition together first: the aggregation of the issue's own table (errors over all detections)
    rows: list[tuple[str, list[dict]]] = [("all conditions", recs)]
    for w in CONDITIONS:
        rw = [r for r in recs if r["water"] == w]
        rows.append((w, rw))
        for lo, hi in ((0.9, 1.3), (1.3, 1.8), (1.8, 2.51)):
            sub = [r for r in rw if lo <= r["range_m"] < hi or r["kind"] == "nopipe" and False]
            if any(r["kind"] != "nopipe" for r in sub):
                rows.append((f"  {w} {lo:.1f}-{min(hi, 2.5):.1f} m", sub))
        for kind in ("pipe", "arm", "partial"):
            sub = [r for r in rw if r["kind"] == kind]
            if sub:
                rows.append((f"  {w} {kind}", sub))
    print(f"{'condition':30s} {'detector':90s} | baseline")
    for name, sub in rows:
        c, b = cell(sub, thr), cell(sub, thr, "baseline")
        fp = (
            f"  false pos {c['false_pos']}/{c['free_views']}, any confidence {c['reported_free']}"
            f" (baseline {b['false_pos']})"
            if c["free_views"]
            else ""
        )
        print(f"{name:30s} {fmt_cell(c)} | {fmt_cell(b)}{fp}")
        out["conditions"][name.strip()] = {"detector": c, "baseline": b}
    passes = res.get("timing_passes_ms") or [[r["wall_ms"] for r in recs]]
    wall = [t for p in passes for t in p]
    cpu = [r["cpu_ms"] for r in recs]
    medians = [pct(p, 50) for p in passes]
    median = float(np.median(medians))
    print(
        f"\ntime per pair at 1292x964, one core, {len(passes)} pass(es) over the {len(passes[0])} pairs "
        "(the first with the baseline and the monocular detector between the pairs): "
        f"median {median:.1f} ms (the passes' medians: {', '.join(f'{m:.1f}' for m in medians)}), "
        f"p90 {pct(wall, 90):.1f} ms, max {max(wall):.1f} ms (cpu median of the first pass {pct(cpu, 50):.1f} ms); "
        f"target <= 50 ms: {'met' if median <= 50 else 'NOT met'} (the median of the passes' medians)"
    )
    out["ms"] = {"median": median, "pass_medians": medians, "p90": pct(wall, 90), "cpu_median": pct(cpu, 50)}
    if any("mono" in r for r in recs):
        print("\nmonocular (left image only):")
        for w in CONDITIONS:
            rw = [r for r in recs if r["water"] == w]
            c = cell(rw, thr, "mono")
            near = [r for r in rw if 1.0 <= r["range_m"] <= 1.5]
            cn = cell(near, thr, "mono")
            print(
                f"  {w:16s} {fmt_cell(c)}  grasp med {c['grasp_med_cm']:.2f} cm; 1-1.5 m: grasp med {cn['grasp_med_cm']:.2f} cm"
            )
            out["conditions"][f"mono {w}"] = c
            out["conditions"][f"mono {w} 1-1.5 m"] = cn
    out["curve"] = confidence_curve(recs)
    out["by_image_condition"] = draw_table(recs, thr, res.get("jpeg_quality") or 0)
    out["by_pipe_contrast"] = contrast_table(recs, thr)
    return out


def draw_table(recs: list[dict], thr: float, jpeg_again: int = 0) -> dict:
    """Prints and returns the detection rate of the pipe views in very turbid water within
    1.3 m (the condition furthest from its target) per bin of each image draw
    (:data:`DRAW_BINS`); the set draws them independently, so each row compares like with like.
    ``jpeg_again``: the quality every image was encoded at again (the JPEG row is the set's own)."""
    sub = [r for r in recs if r["water"] == "very_turbid" and r["kind"] != "nopipe" and 0.9 <= r["range_m"] < 1.3]
    missing = sum("image" not in r for r in sub)
    if missing:
        raise SystemExit(f"{missing} record(s) without the image draws (written by an older version): run again")
    again = f"; JPEG: the set's own, before the encoding again at quality {jpeg_again}" if jpeg_again else ""
    print(
        f"\nvery turbid water within 1.3 m by image condition ({len(sub)} pipe views,"
        f" detected = confidence >= {thr:g}{again}):"
    )
    out: dict = {}
    for name, key, bins in DRAW_BINS:
        out[name], cells = binned(sub, lambda r, key=key: r["image"].get(key), bins, thr)
        print(f"  {name:12s} " + " | ".join(cells))
    return out


def binned(recs: list[dict], value_of: Any, bins: tuple[DrawBin, ...], thr: float, width: int = 0) -> tuple[dict, list]:
    """Per bin of ``bins`` (the value ``value_of(record)``): its views and those detected at
    ``thr``, and the printed cells (labels right-aligned to ``width``)."""
    counts, cells = {}, []
    for b in bins:
        members = [r for r in recs if b.holds(value_of(r))]
        hits = sum(r["confidence"] >= thr for r in members)
        counts[b.label] = {"views": len(members), "detected": hits}
        rate = f"{100 * hits / len(members):3.0f} %" if members else "  - "
        cells.append(f"{b.label:>{width}s} {hits:3d}/{len(members):3d} {rate}")
    return counts, cells


def contrast_table(recs: list[dict], thr: float) -> dict:
    """Prints and returns the detection rate of the pipe views per bin of the pipe's contrast
    against the floor beside it (:data:`CONTRAST_BINS`), over every water and over very turbid
    water within 1.3 m: the detector's detection limit in terms of the image alone, whatever
    made the contrast small (the water, the lamps, the range, the floor's colour)."""
    pipe = [r for r in recs if r["kind"] != "nopipe"]
    missing = sum("pipe_contrast" not in r for r in pipe)
    if missing:
        raise SystemExit(f"{missing} record(s) without the pipe's contrast (written by an older version): run again")
    measured = [r for r in pipe if r["pipe_contrast"] is not None]
    print(
        f"\nby the pipe's contrast against the floor beside it (left image as the detector got it, 8-bit levels;"
        f" {len(measured)} pipe views, {len(pipe) - len(measured)} with too little of the pipe in view to measure;"
        f" detected = confidence >= {thr:g}):"
    )
    out: dict = {}
    subsets = (
        ("every water", measured),
        (
            "very turbid within 1.3 m",
            [r for r in measured if r["water"] == "very_turbid" and 0.9 <= r["range_m"] < 1.3],
        ),
    )
    for subset, members_of in subsets:
        for name, key, bins in CONTRAST_BINS:
            counts, cells = binned(members_of, lambda r, key=key: r["pipe_contrast"][key], bins, thr, 5)
            out.setdefault(subset, {})[name] = counts
            print(f"  {subset:25s} {name:7s} " + " | ".join(cells))
    return out


def pooled(paths: list[str]) -> None:
    """The tables by image condition and by the pipe's contrast over the records of several
    ``--json`` outputs (one per split, all at the same threshold and re-encoding)."""
    recs: list[dict] = []
    runs: dict[str, tuple] = {}
    for p in paths:
        try:
            doc = json.loads(Path(p).read_text())
            run_of = (doc["threshold"], doc.get("jpeg_quality") or 0)
            split = str(doc["split"])
        except (OSError, ValueError, KeyError, TypeError) as e:
            raise SystemExit(f"{p}: not a --json output of this benchmark ({type(e).__name__}: {e})") from None
        if split in runs:
            raise SystemExit(f"{p}: split '{split}' given twice: each view would count twice")
        runs[split] = run_of
        recs += doc.get("records", [])
    if len(set(runs.values())) != 1:
        raise SystemExit(
            "the files differ in threshold or JPEG re-encoding ("
            + ", ".join(f"{k}: {v[0]:g}, {v[1]}" for k, v in runs.items())
            + "): pool like with like"
        )
    thr, again = next(iter(runs.values()))
    print(f"pooled: splits {', '.join(runs)} ({', '.join(paths)})")
    draw_table(recs, float(thr), int(again))
    contrast_table(recs, float(thr))


def answer_confidence(r: dict) -> float:
    """The confidence of the detector's answer in record ``r``, reported or not (an answer under
    ``DetectorConfig.min_reported_confidence`` is reported as no pipe, its confidence kept in
    ``quality['confidence_unreported']``)."""
    c = float(r.get("confidence", 0.0))
    return c if c > 0.0 else float(r.get("quality", {}).get("confidence_unreported", 0.0))


def confidence_curve(recs: list[dict]) -> list[dict]:
    """Error versus confidence over all pipe views the detector answered, reported or not."""
    pipe = [r for r in recs if r["kind"] != "nopipe" and answer_confidence(r) > 0 and "axis_deg" in r]
    edges = [0.0, 0.2, 0.4, 0.5, 0.6, 0.7, 0.8, 0.9, 1.01]
    rows = []
    print(
        "\nerror versus confidence (pipe views; 'good' = axis <= 2 deg and grasp point within 2 cm, where an end was seen):"
    )
    print(
        f"{'confidence':>12s} {'n':>4s} {'axis med/p90 deg':>18s} {'offset med/p90 cm':>19s} {'end med/p90 cm':>16s} {'wrong':>6s} {'good':>6s}"
    )
    for lo, hi in zip(edges[:-1], edges[1:]):
        sub = [r for r in pipe if lo <= answer_confidence(r) < hi]
        if not sub:
            continue
        ax = [r["axis_deg"] for r in sub]
        off = [100 * r["offset_m"] for r in sub]
        end = [100 * r["end_m"] for r in sub if "end_m" in r]
        good = [r for r in sub if r["axis_deg"] <= 2.0 and r["offset_m"] <= 0.02 and r.get("grasp_m", 0.0) <= 0.02]
        row = {
            "lo": lo,
            "hi": min(hi, 1.0),
            "n": len(sub),
            "axis_med": pct(ax, 50),
            "axis_p90": pct(ax, 90),
            "offset_med_cm": pct(off, 50),
            "offset_p90_cm": pct(off, 90),
            "end_med_cm": pct(end, 50),
            "end_p90_cm": pct(end, 90),
            "wrong": sum(bool(r.get("wrong")) for r in sub),
            "good": len(good) / len(sub),
        }
        rows.append(row)
        print(
            f"{lo:5.2f}-{min(hi, 1.0):4.2f} {len(sub):6d} {row['axis_med']:8.2f}/{row['axis_p90']:6.2f} "
            f"{row['offset_med_cm']:9.2f}/{row['offset_p90_cm']:6.2f} {row['end_med_cm']:7.2f}/{row['end_p90_cm']:6.2f} "
            f"{row['wrong']:6d} {100 * row['good']:5.0f} %"
        )
    return rows


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    from sim_backend.evalset import SPLIT_SEEDS

    ap.add_argument("--split", default="eval", choices=tuple(SPLIT_SEEDS))
    ap.add_argument("--scale", type=float, default=1.0, help="fraction of the set (at least one view per row)")
    ap.add_argument("--cache", default=None, help="folder for the rendered pairs")
    ap.add_argument("--threshold", type=float, default=None, help="detection threshold (default: the mission's)")
    ap.add_argument("--json", default=None, help="write every record and the tables here")
    ap.add_argument(
        "--timing-passes",
        type=int,
        default=3,
        help="times the detector runs over the pairs for the time per pair (the host's speed moves between passes)",
    )
    ap.add_argument(
        "--jpeg-quality",
        type=int,
        default=0,
        help="JPEG-encode every image again at this quality (1-100) before the detector and the baseline,"
        " as a compressed camera stream would be (0: the set as rendered)",
    )
    ap.add_argument(
        "--pooled",
        nargs="+",
        metavar="JSON",
        default=None,
        help="print the tables by image condition and by the pipe's contrast over these --json outputs (e.g. of the three splits) and stop",
    )
    args = ap.parse_args()
    if args.pooled:
        pooled(args.pooled)
        return
    if not 0 <= args.jpeg_quality <= 100:
        ap.error(f"--jpeg-quality must be within 0-100, got {args.jpeg_quality}")
    if args.threshold is None:
        args.threshold = mission_threshold()
    res = run(args)
    out = print_tables(res)
    if args.json:
        Path(args.json).write_text(json.dumps({**res, "tables": out}, indent=1, default=float))
    summary = {k: v["detector"]["rate"] for k, v in out["conditions"].items() if k in CONDITIONS}
    print("vision_evalset " + json.dumps({"rates": summary, "ms_median": round(out["ms"]["median"], 1)}))


if __name__ == "__main__":
    main()
