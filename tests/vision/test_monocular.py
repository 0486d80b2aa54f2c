"""The monocular mode: one camera's two tangent planes and the known radius fix the axis."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from vision.cylinder import Plane, axis_from_one_camera, fit_axis
from vision.errors import VisionInputError
from vision.monocular import MonocularPipeDetector

from .conftest import errors


def tangent_planes(p: np.ndarray, a: np.ndarray, r: float, centre: np.ndarray) -> tuple[Plane, Plane]:
    """The two planes through ``centre`` tangent to the cylinder (axis point ``p``,
    unit direction ``a``, radius ``r``), normals towards the cylinder."""
    w = p - centre
    w = w - (w @ a) * a
    dist = np.linalg.norm(w)
    e = w / dist
    f = np.cross(a, e)
    s = r / dist
    c = np.sqrt(1 - s * s)
    planes = []
    for sign in (1.0, -1.0):
        n = s * e + sign * c * f  # n . (p - centre) = r, n . a = 0
        planes.append(Plane(n, float(n @ centre)))
    return planes[0], planes[1]


@settings(max_examples=60, deadline=None)
@given(
    p=st.tuples(st.floats(-1.0, 1.0), st.floats(-1.0, 1.0), st.floats(0.6, 3.0)),
    a=st.tuples(st.floats(-1, 1), st.floats(-1, 1), st.floats(-1, 1)),
    r=st.floats(0.01, 0.2),
    centre=st.tuples(st.floats(-0.3, 0.3), st.floats(-0.1, 0.1), st.floats(-0.1, 0.1)),
)
def test_two_tangent_planes_and_the_radius_give_the_axis(p, a, r, centre) -> None:  # noqa: ANN001
    """r / sin(half the angle between the planes) from their common line, on their bisector."""
    p, a, centre = np.array(p), np.array(a), np.array(centre)
    if np.linalg.norm(a) < 0.2:
        a = np.array([1.0, 0.2, 0.1])
    a = a / np.linalg.norm(a)
    w = p - centre - ((p - centre) @ a) * a
    if np.linalg.norm(w) < 3 * r:  # the camera inside or right at the pipe
        return
    P1, P2 = tangent_planes(p, a, r, centre)
    fit = axis_from_one_camera(P1, P2, r, centre)
    assert fit is not None
    assert abs(abs(fit.a @ a) - 1.0) < 1e-9
    # the same line: the fitted point lies on the true axis
    d = fit.p - p
    assert np.linalg.norm(d - (d @ a) * a) < 1e-9
    assert abs(fit.p @ fit.a) < 1e-9  # the point closest to the left camera centre, as fit_axis gives it
    # the least-squares fit of fit_axis with the radius as a prior agrees
    ls = fit_axis([P1, P2], r, 1.0)
    assert ls is not None and np.linalg.norm(ls.p - fit.p) < 1e-6


def test_parallel_planes_fix_no_axis() -> None:
    n = np.array([1.0, 0.0, 0.0])
    assert axis_from_one_camera(Plane(n, 0.0), Plane(n, 0.0), 0.05, np.zeros(3)) is None


def test_one_camera_finds_the_rendered_pipe(calib, clear_case) -> None:  # noqa: ANN001
    mono = MonocularPipeDetector(calib.left)
    det = mono.detect(clear_case.left, gravity_cam=clear_case.gravity_cam)
    pos, ang = errors(det, clear_case)
    assert det.found and det.confidence > 0.6, det.reason
    assert pos < 0.02 and ang < 2.0, (pos, ang)
    assert det.quality["views_used"] == "2+0" and "one camera" in det.reason


def test_monocular_bad_input(calib, clear_case) -> None:  # noqa: ANN001
    mono = MonocularPipeDetector(calib.left)
    with pytest.raises(VisionInputError, match="image: missing"):
        mono.detect(None)  # type: ignore[arg-type]
    with pytest.raises(VisionInputError, match="expected an 8-bit colour"):
        mono.detect(clear_case.left[:, :, 0].copy())
    with pytest.raises(VisionInputError, match="different aspect ratio"):
        mono.detect(clear_case.left[:300].copy())
