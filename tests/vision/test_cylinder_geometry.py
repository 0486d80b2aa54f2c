"""The geometry of the detector against exact synthetic data (no images)."""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from vision.cylinder import AxisFit, fit_axis, fit_end, grasp_rotation, plane_from_line, rim_points
from vision.refine import rim_distance

R_RIGHT = np.eye(3)
T_RIGHT = np.array([-0.2, 0.0, 0.0])  # right camera 0.2 m to the right


def tangent_normals(p: np.ndarray, a: np.ndarray, r: float, C: np.ndarray) -> list[np.ndarray]:
    """Normals of the two planes through C tangent to the cylinder (p, a, r)."""
    w = p - C
    w = w - (w @ a) * a
    d = np.linalg.norm(w)
    e, f = w / d, np.cross(a, w / d)
    s, c = r / d, np.sqrt(1 - (r / d) ** 2)
    return [c * f - s * e, -c * f - s * e]


def planes_for(p: np.ndarray, a: np.ndarray, r: float) -> list:
    out = []
    for j, (R, t) in enumerate(((np.eye(3), np.zeros(3)), (R_RIGHT, T_RIGHT))):
        C = -R.T @ t
        for n in tangent_normals(p, a, r, C):
            out.append(plane_from_line(R @ n, R, t, R @ (p - C), j))
    return out


@settings(max_examples=60, deadline=None)
@given(
    st.floats(-0.5, 0.5),
    st.floats(-0.4, 0.4),
    st.floats(0.7, 3.0),
    st.floats(0.0, np.pi),
    st.floats(-0.6, 0.6),
    st.floats(0.02, 0.1),
)
def test_axis_and_radius_from_four_tangent_planes(
    x: float, y: float, z: float, yaw: float, tilt: float, r: float
) -> None:
    p = np.array([x, y, z])
    a = np.array([np.cos(yaw) * np.cos(tilt), np.sin(tilt), np.sin(yaw) * np.cos(tilt)])
    a /= np.linalg.norm(a)
    if abs(a @ np.array([1.0, 0.0, 0.0])) > 0.97:  # nearly along the baseline: depth from the radius prior only
        return
    for C in (np.zeros(3), np.array([0.2, 0.0, 0.0])):  # a camera inside the pipe, or looking down its bore: no limbs
        w = p - C
        if np.linalg.norm(w - (w @ a) * a) < 3.0 * r:
            return
    fit = fit_axis(planes_for(p, a, r), radius_prior=None)
    assert fit is not None and fit.n_cameras == 2
    assert abs(abs(fit.a @ a) - 1.0) < 1e-9
    off = fit.p - p
    assert np.linalg.norm(off - (off @ a) * a) < 1e-7
    assert abs(fit.r - r) < 1e-8


def test_one_camera_needs_the_radius() -> None:
    p, a, r = np.array([0.1, 0.2, 1.5]), np.array([0.0, 0.6, 0.8]), 0.05
    left = [pl for pl in planes_for(p, a, r) if pl.camera == 0]
    assert fit_axis(left, radius_prior=None) is None
    fit = fit_axis(left, radius_prior=r)
    off = fit.p - p
    assert np.linalg.norm(off - (off @ a) * a) < 1e-7


def test_end_fit_recovers_the_cap_position_from_rim_outline_points() -> None:
    a = np.array([0.2, 0.55, 0.8])
    a /= np.linalg.norm(a)
    fit = AxisFit(np.array([0.05, -0.1, 1.3]), a, 0.05, 0.0, 0.0, 1.0, 2)
    s_true = 0.37
    rim = rim_points(fit, s_true)
    cams = []
    for R, t in ((np.eye(3), np.zeros(3)), (R_RIGHT, T_RIGHT)):
        X = rim @ R.T + t
        cams.append((R, t, X[::3, :2] / X[::3, 2:], 600.0))
        E = R @ (fit.p + s_true * a) + t
        assert np.abs(rim_distance(X[:, :2] / X[:, 2:], E, R @ a, fit.r)).max() < 1e-9
    s, rms = fit_end(fit, 0.3, 0.2, cams)
    assert abs(s - s_true) < 1e-3 and rms < 0.1


def test_grasp_rotation_takes_the_roll_from_gravity() -> None:
    axis = np.array([0.3, 0.1, 0.95])
    g = np.array([0.0, 0.8, 0.6])
    R, sin_g = grasp_rotation(axis, g, np.array([0.0, 1.0, 0.0]))
    np.testing.assert_allclose(R.T @ R, np.eye(3), atol=1e-12)
    assert np.linalg.det(R) > 0.999
    np.testing.assert_allclose(R[:, 0], axis / np.linalg.norm(axis), atol=1e-12)
    assert abs(R[:, 1] @ g) < 1e-12 and R[:, 2] @ g > 0  # z points down, y is level
    assert 0.0 < sin_g <= 1.0
