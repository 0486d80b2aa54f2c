"""The colour region: which connected pieces make the pipe, and the region at full resolution."""

from __future__ import annotations

import cv2
import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from vision.silhouette import select_region, upsampled_mask


def _band(mask: np.ndarray, p0: tuple[float, float], p1: tuple[float, float], width: int) -> None:
    cv2.line(mask, (int(p0[0]), int(p0[1])), (int(p1[0]), int(p1[1])), 255, width)


def test_pieces_of_the_pipe_join_and_a_tile_on_its_line_does_not() -> None:
    mask = np.zeros((300, 500), np.uint8)
    _band(mask, (40, 150), (250, 150), 20)  # the pipe, cut by the arm ...
    _band(mask, (290, 150), (380, 150), 20)  # ... its other piece
    cv2.rectangle(mask, (420, 120), (480, 180), 255, -1)  # a pipe-coloured tile beyond it, on its line
    region, why = select_region(mask, 50)
    assert region is not None and why == ""
    full = region.full()
    assert full[150, 300] == 255 and full[150, 100] == 255
    assert full[150, 450] == 0


@settings(max_examples=30, deadline=None)
@given(st.floats(0.0, np.pi), st.floats(4.0, 30.0), st.floats(-0.5, 0.5), st.floats(-0.5, 0.5))
def test_a_mask_brought_to_full_resolution_keeps_its_edges(angle: float, half: float, dx: float, dy: float) -> None:
    """A band thresholded on every third pixel comes back at full resolution with its
    edges within a reduced pixel (3 px) of the band's."""
    h, w = 321, 430
    c = np.array([w / 2 + dx, h / 2 + dy]) * 3.0
    u = np.array([np.cos(angle), np.sin(angle)])
    n = np.array([-u[1], u[0]])
    yy, xx = np.mgrid[0:h, 0:w].astype(float) * 3.0  # the reduced pixels' full-resolution positions
    small = ((np.abs((xx - c[0]) * n[0] + (yy - c[1]) * n[1]) <= 3.0 * half) * 255).astype(np.uint8)
    full = upsampled_mask(small, 3 * w, 3 * h)
    Y, X = np.mgrid[0 : 3 * h, 0 : 3 * w].astype(float)
    dist = np.abs((X - c[0]) * n[0] + (Y - c[1]) * n[1])
    inner = (X > 6) & (Y > 6) & (X < 3 * w - 7) & (Y < 3 * h - 7)
    assert np.all(full[(dist < 3 * half - 3.0) & inner] == 255)
    assert np.all(full[(dist > 3 * half + 3.0) & inner] == 0)
