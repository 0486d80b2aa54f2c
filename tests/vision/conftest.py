"""Rendered stereo pairs with known truth, shared by the vision tests (cached per session);
this folder's helper modules (``rim_scene``) importable by the tests."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

from sim_backend.render import StereoRenderer
from sim_backend.render_cases import default_calibration, view_case, visibility
from sim_backend.render_optics import WaterOptics

sys.path.insert(0, str(Path(__file__).parent))


@pytest.fixture(scope="session")
def calib():  # noqa: ANN201
    return default_calibration()


@pytest.fixture(scope="session")
def renderers(calib):  # noqa: ANN001, ANN201
    return {
        t: StereoRenderer(calib, WaterOptics.for_visibility(visibility(t)), np.random.default_rng(3))
        for t in ("clear", "slightly_turbid", "very_turbid")
    }


@pytest.fixture(scope="session")
def clear_case(calib, renderers):  # noqa: ANN001, ANN201
    """The pipe 1.25 m away, seen obliquely, one end well in view, clear water."""
    return view_case(1.25, elevation=0.96, azimuth=1.1, aim_offset_m=0.25, calib=calib, renderer=renderers["clear"])


def errors(det, case) -> tuple[float, float]:  # noqa: ANN001
    """(position error m, axis error deg) of a detection against the case's truth."""
    T, G = det.cam_T_grasp, case.cam_T_grasp
    pos = float(np.linalg.norm(T[:3, 3] - G[:3, 3]))
    ang = float(np.degrees(np.arccos(min(1.0, abs(float(T[:3, 0] @ G[:3, 0]))))))
    return pos, ang
