"""``maris vision tune``: HSV thresholds from an operator's own image.

Inside the box around the pipe (``--roi``, or the current thresholds' largest
region grown by a margin) and in a ring around it, it prints hue, saturation
and value percentiles (OpenCV scales), suggests thresholds that keep 95 % of
the pipe's pixels while rejecting the surroundings, and writes mask previews:
``mask_current.png`` and ``mask_suggested.png`` (the image, dimmed where the
mask rejects), plus how much of the box and of the ring each mask keeps.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

# Imports inside the functions below are deliberate: shell completion (argcomplete) builds
# the parser on every Tab, so a command loads its heavy modules only when it runs.


def _box(text: str) -> tuple[int, int, int, int]:
    vals = [int(float(x)) for x in text.split(",")]
    if len(vals) != 4 or vals[2] <= 0 or vals[3] <= 0:
        raise ValueError("--roi: expected X,Y,W,H with W, H > 0")
    return vals[0], vals[1], vals[2], vals[3]


def tune(args: argparse.Namespace) -> int:
    import cv2
    import numpy as np

    from vision.silhouette import HsvRange, hsv_mask, select_region

    img = cv2.imread(args.image, cv2.IMREAD_COLOR)
    if img is None:
        print(
            f"maris vision tune: {args.image}: cannot read the image (missing, corrupt or not an image)",
            file=sys.stderr,
        )
        return 2
    h, w = img.shape[:2]
    try:
        parts = [int(float(x)) for x in args.hue.split(",")] if args.hue else [22, 35]
        if len(parts) != 2:
            raise ValueError("--hue: expected LO,HI")
        current = HsvRange(hue=(parts[0], parts[1]), sat_min=args.sat_min, val_min=args.val_min)
        errs = current.check()
        if errs:
            raise ValueError("; ".join(errs))
        if args.roi:
            x, y, bw, bh = _box(args.roi)
        else:
            region, why = select_region(hsv_mask(img, current), max(12, int(2e-4 * w * h)))
            if region is None:
                raise ValueError(f"the current thresholds find nothing ({why}): give the pipe's box with --roi X,Y,W,H")
            x, y, bw, bh = region.x0, region.y0, region.mask.shape[1], region.mask.shape[0]
    except ValueError as exc:
        print(f"maris vision tune: {exc}", file=sys.stderr)
        return 2
    x0, y0, x1, y1 = max(x, 0), max(y, 0), min(x + bw, w), min(y + bh, h)
    if x1 <= x0 or y1 <= y0:
        print(f"maris vision tune: the box {x},{y},{bw},{bh} is outside the {w}x{h} image", file=sys.stderr)
        return 2
    hsv = cv2.cvtColor(img, cv2.COLOR_BGR2HSV)
    inside = np.zeros((h, w), bool)
    inside[y0:y1, x0:x1] = True
    m = max(10, (x1 - x0 + y1 - y0) // 4)
    ring = np.zeros((h, w), bool)
    ring[max(y0 - m, 0) : min(y1 + m, h), max(x0 - m, 0) : min(x1 + m, w)] = True
    ring &= ~inside
    box_px, ring_px = hsv[inside], hsv[ring]
    # the pipe's pixels in the box: those unlike the surroundings (more saturated, or
    # of a hue the surroundings do not have); the box also holds background
    if len(ring_px):
        s_bg = float(np.percentile(ring_px[:, 1], 99))
        h_lo_bg, h_hi_bg = np.percentile(ring_px[:, 0], [1, 99])
        unlike = (box_px[:, 1] > s_bg + 5) | (
            ((box_px[:, 0] < h_lo_bg) | (box_px[:, 0] > h_hi_bg)) & (box_px[:, 1] > 20)
        )
        pipe_px = box_px[unlike] if unlike.sum() >= 20 else box_px
    else:
        s_bg, pipe_px = 0.0, box_px
    pct = lambda a, q: np.percentile(a, q, axis=0).astype(int).tolist()  # noqa: E731 - rows: percentiles, columns: H, S, V
    print(
        f"image {args.image}: {w}x{h}, pipe box x={x0} y={y0} w={x1 - x0} h={y1 - y0}, surroundings {int(ring.sum())} px"
    )
    print(f"  {len(pipe_px)} px of the box stand out from the surroundings (taken as the pipe)")
    print("                                   hue (0-179)   saturation     value")
    for name, arr in (("pipe", pipe_px), ("surroundings", ring_px)):
        if len(arr) == 0:
            continue
        p = pct(arr, [5, 50, 95])
        print(f"  {name:14s} 5/50/95 %:     " + "   ".join(f"{p[0][c]:3d} {p[1][c]:3d} {p[2][c]:3d}" for c in range(3)))
    h_lo, h_hi = (int(v) for v in np.percentile(pipe_px[:, 0], [2.5, 97.5]))
    s_pipe = float(np.percentile(pipe_px[:, 1], 5))
    s_min = int(round(0.5 * (s_pipe + s_bg))) if s_bg < s_pipe else int(s_pipe)
    v_min = max(int(np.percentile(pipe_px[:, 2], 1)) - 5, 0)
    suggested = HsvRange(hue=(max(h_lo - 2, 0), min(h_hi + 2, 179)), sat_min=max(s_min, 1), val_min=v_min)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    for name, rng in (("current", current), ("suggested", suggested)):
        mask = hsv_mask(img, rng) > 0
        keep_box, keep_ring = mask[inside].mean(), (mask[ring].mean() if ring.any() else 0.0)
        preview = (img * np.where(mask[..., None], 1.0, 0.25)).astype(np.uint8)
        cv2.rectangle(preview, (x0, y0), (x1 - 1, y1 - 1), (255, 255, 255), 1)
        path = out / f"mask_{name}.png"
        cv2.imwrite(str(path), preview)
        print(
            f"  {name:9s} hue {list(rng.hue)} sat >= {rng.sat_min} val >= {rng.val_min}: keeps {100 * keep_box:.0f} % of the box, "
            f"{100 * keep_ring:.1f} % of the surroundings -> {path}"
        )
    print(
        f"use: --hue {suggested.hue[0]},{suggested.hue[1]} --sat-min {suggested.sat_min} --val-min {suggested.val_min}"
        f"  (HAL config: hsv: {{hue: [{suggested.hue[0]}, {suggested.hue[1]}], sat_min: {suggested.sat_min}, val_min: {suggested.val_min}}})"
    )
    return 0
