"""Where a limb is placed on a lit, blurred cylinder.

A cylinder lit from the camera's side darkens towards its limbs (its surface
turns away from the light), so the pipe score's half level between the inside
(2-5 px in) and the background lies inside the silhouette; the limb search
moves its line out by ``EdgeSearch.limb_inset_px`` for that. Drawn here: a
horizontal pipe with Lambertian shading across it (a share of ambient light),
a Gaussian optical blur, the pipe's silhouette at known rows; the limbs found
must be those rows within 0.3 px (without the move they lie 0.1-0.6 px inside,
0.3 px in the median).
"""

from __future__ import annotations

import cv2
import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from vision.calibration import CameraModel
from vision.silhouette import EdgeSearch, Region, analyse

W, H = 640, 400


def _lit_pipe(top: float, radius: float, ambient: float, blur: float) -> np.ndarray:
    """BGR image: a yellow pipe between rows ``top`` and ``top + 2 radius`` (sub-pixel,
    area-sampled 8x), lit from the camera (brightness ``ambient + (1 - ambient) cos``
    of the surface's angle), on a blue-grey floor, blurred (Gaussian ``blur`` px)."""
    s = 8
    y = (np.arange(H * s) + 0.5) / s
    d = (y - top - radius) / radius  # -1..1 across the pipe
    inside = np.abs(d) < 1.0
    shade = np.where(inside, ambient + (1.0 - ambient) * np.sqrt(np.clip(1.0 - d * d, 0.0, 1.0)), 0.0)
    shade = shade.reshape(H, s).mean(axis=1)
    cover = inside.reshape(H, s).mean(axis=1)
    pipe = np.array([40.0, 200.0, 230.0])  # BGR yellow
    floor = np.array([120.0, 110.0, 90.0])
    col = (1.0 - cover)[:, None] * floor + shade[:, None] * pipe  # (H, 3)
    img = np.repeat(col[:, None, :], W, axis=1).astype(np.float32)
    img = cv2.GaussianBlur(img, (0, 0), blur)
    return np.clip(img, 0, 255).astype(np.uint8)


@settings(max_examples=12, deadline=None)
@given(st.floats(150.0, 160.0), st.floats(25.0, 45.0), st.floats(0.3, 0.6), st.floats(0.7, 1.3))
def test_the_limbs_of_a_lit_blurred_pipe_are_on_its_silhouette(
    top: float, radius: float, ambient: float, blur: float
) -> None:
    img = _lit_pipe(top, radius, ambient, blur)
    mask = np.zeros((H, W), np.uint8)
    mask[int(np.ceil(top)) + 2 : int(top + 2 * radius) - 2, 20 : W - 20] = 255  # a colour region a bit inside
    cam = CameraModel(W, H, np.array([[500.0, 0.0, W / 2], [0.0, 500.0, H / 2], [0.0, 0.0, 1.0]]), np.zeros(5))
    sil = analyse(Region(mask, 0, 0, (H, W)), cam, None, img, search=EdgeSearch())
    assert len(sil.limbs) == 2
    rows = sorted(float(np.median(lb.points[:, 1])) for lb in sil.limbs)
    edges = (top - 0.5, top + 2 * radius - 0.5)  # pixel i spans rows i - 0.5 .. i + 0.5 for the detector
    assert abs(rows[0] - edges[0]) < 0.3, (rows, edges)
    assert abs(rows[1] - edges[1]) < 0.3, (rows, edges)
