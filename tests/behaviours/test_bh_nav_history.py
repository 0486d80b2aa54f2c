"""NavHistory: vehicle pose at a past time, and its use for detections."""

from __future__ import annotations

import numpy as np

from behaviours.geometry import grasp_pose_world
from behaviours.nav_history import NavHistory
from hal.interfaces import Detection, NavigationState


def nav(t, x, yaw):
    return NavigationState(t, np.array([x, 0.0, 2.0]), np.array([0.0, 0.0, yaw]), None, None, 2.0, 1.5)


def test_interpolates_position_and_wraps_yaw():
    h = NavHistory()
    h.add(nav(0.0, 0.0, np.pi - 0.1))
    h.add(nav(0.1, 1.0, -np.pi + 0.1))  # crossed +-pi: the short way is +0.2 rad
    eta = h.eta_at(0.05)
    assert np.isclose(eta[0], 0.5)
    assert np.isclose(abs(eta[5]), np.pi)
    assert np.allclose(h.eta_at(-1.0), [0, 0, 2, 0, 0, np.pi - 0.1])  # before: oldest
    assert np.allclose(h.eta_at(5.0)[0], 1.0)  # after: newest


def test_ignores_old_nonfinite_and_far_gaps():
    h = NavHistory(span_s=1.0, max_gap_s=0.5)
    assert h.eta_at(0.0) is None
    h.add(nav(0.0, 0.0, 0.0))
    h.add(nav(0.0, 9.0, 0.0))  # not newer
    h.add(nav(0.1, float("nan"), 0.0))
    assert len(h) == 1
    h.add(nav(2.0, 2.0, 0.0))  # 2 s gap: no interpolation across it
    assert np.isclose(h.eta_at(0.4)[0], 0.0) and np.isclose(h.eta_at(1.6)[0], 2.0)
    for k in range(30):
        h.add(nav(2.1 + 0.1 * k, 0.0, 0.0))
    assert len(h) <= 12  # keeps about span_s of samples


def test_detection_is_placed_with_the_pose_at_its_image_time():
    h = NavHistory()
    h.add(nav(0.0, 0.0, 0.0))
    h.add(nav(0.4, 0.4, 0.0))
    vTg = np.eye(4)
    vTg[:3, 3] = [2.0, 0.0, 1.0]
    det = Detection(0.1, vTg, 0.9)
    latest = nav(0.4, 0.4, 0.0)
    assert np.allclose(grasp_pose_world(latest, det, h)[:3, 3], [2.1, 0.0, 3.0])
    assert np.allclose(grasp_pose_world(latest, det)[:3, 3], [2.4, 0.0, 3.0])  # without history: latest pose
