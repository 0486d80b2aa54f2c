"""The geometry of one image of the table vision model, compiled (:mod:`sim_backend.vision`).

:func:`image_view` computes at each image (~10 Hz) what
:meth:`sim_backend.vision.VisionModel.probability` decides from: the grasp
point in the camera frame, its range, whether it is inside the field of view
and the usable range, and whether an arm link hides it (:func:`sim_backend.vision.occluded`:
5 points per link, a cylinder of ``occlusion_radius_m`` around the line of
sight). Same formulas as the numpy functions of :mod:`sim_backend.vision`, in
one call instead of some thirty numpy calls on 3-vectors; the sums are in
another order, so the range agrees with the numpy code to rounding (~1e-16
relative), not bit for bit (``tests/sim_backend/test_sim_vision.py`` compares
both on random views).

Parameters ``par`` (``V_*`` indices): full field-of-view angles (rad), the
usable range (m), the occlusion radius (m). Results ``out`` (``O_*``): range
(m), in view (1/0), occluded (1/0), the grasp point in the camera frame (3, m).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

V_FOV_H, V_FOV_V, V_MIN_RANGE, V_MAX_RANGE, V_OCC_RADIUS = range(5)
N_V = 5
O_RANGE, O_IN_VIEW, O_OCCLUDED, O_TARGET = 0, 1, 2, 3
N_O = 6

#: the occlusion test's margin (m): a link must be this much closer than the target (vision.points_block_ray)
OCC_MARGIN_M = 0.1
#: points per link along the segment (vision.sample_segments: linspace(0, 1, 5))
_SAMPLES = np.linspace(0.0, 1.0, 5)


@njit(cache=True)
def image_view(wTc: np.ndarray, wTg: np.ndarray, arm_w: np.ndarray, par: np.ndarray, samples: np.ndarray,
               out: np.ndarray) -> None:
    """The view of the grasp frame ``wTg`` (4, 4, world) from the camera at ``wTc`` (4, 4,
    world) with the arm points ``arm_w`` (k, 3, world) into ``out`` (see the module docstring);
    ``samples``: the fractions along each link where the occlusion is tested."""
    # the grasp point in the camera frame: R^T (g - p), as inverse_pose then R.dot(g) + o
    tx = ty = tz = 0.0
    ox = oy = oz = 0.0
    for j in range(3):
        p = wTc[j, 3]
        g = wTg[j, 3]
        tx += wTc[j, 0] * g
        ty += wTc[j, 1] * g
        tz += wTc[j, 2] * g
        ox -= wTc[j, 0] * p
        oy -= wTc[j, 1] * p
        oz -= wTc[j, 2] * p
    tx += ox
    ty += oy
    tz += oz
    out[O_TARGET] = tx
    out[O_TARGET + 1] = ty
    out[O_TARGET + 2] = tz
    rng = math.sqrt(tx * tx + ty * ty + tz * tz)
    out[O_RANGE] = rng
    in_view = (tz > 0.0 and abs(math.atan2(tx, tz)) <= 0.5 * par[V_FOV_H] and abs(math.atan2(ty, tz)) <= 0.5 * par[V_FOV_V]
               and par[V_MIN_RANGE] <= rng <= par[V_MAX_RANGE])
    out[O_IN_VIEW] = 1.0 if in_view else 0.0
    occ = False
    k = arm_w.shape[0]
    if in_view and k >= 2 and rng > 0.0:
        dx, dy, dz = tx / rng, ty / rng, tz / rng
        r2 = par[V_OCC_RADIUS] * par[V_OCC_RADIUS]
        limit = rng - OCC_MARGIN_M
        for i in range(k - 1):
            # the link's end points in the camera frame: R^T x + o
            a0 = a1 = a2 = b0 = b1 = b2 = 0.0
            for j in range(3):
                xa = arm_w[i, j]
                xb = arm_w[i + 1, j]
                a0 += wTc[j, 0] * xa
                a1 += wTc[j, 1] * xa
                a2 += wTc[j, 2] * xa
                b0 += wTc[j, 0] * xb
                b1 += wTc[j, 1] * xb
                b2 += wTc[j, 2] * xb
            a0 += ox
            a1 += oy
            a2 += oz
            b0 += ox
            b1 += oy
            b2 += oz
            for s in samples:
                px = a0 + s * (b0 - a0)
                py = a1 + s * (b1 - a1)
                pz = a2 + s * (b2 - a2)
                along = px * dx + py * dy + pz * dz
                perp2 = (px * px + py * py + pz * pz) - along * along
                if along > 0.0 and along < limit and perp2 < r2:
                    occ = True
                    break
            if occ:
                break
    out[O_OCCLUDED] = 1.0 if occ else 0.0
