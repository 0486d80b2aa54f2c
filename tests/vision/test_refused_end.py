"""A refused end along the rim of a ``2+1`` axis as evidence against that axis.

With two edges in one camera and one in the other, a wrong axis can turn in depth
about a point near one pipe end, where it crosses the true axis: both cameras then
see that end's rim at the same place along it and confirm it, while the other end's
image falls at another place along the axis in each camera, and that end is refused
(``test_rim_end_confirmation.py``). The refused end still says two things: where the
cameras' mean fall along the rim stands out, at a distance from the taken end that
the pipe's length checks as two taken ends' would; and, where a camera in view of the
end places it elsewhere along the axis, that the axis is off in depth there. A right
axis with an end too faint in one camera to be confirmed keeps its confidence: that
camera's own best is at the end, and the distance is the pipe's length.

The scenes (``rim_scene.py``): a capped 1 m pipe, both ends in view, its edges drawn as
the tangents of the true cylinder or of one turned in depth about the pipe's end at
``+a``.
"""

from __future__ import annotations

import cv2
import numpy as np
import pytest
from rim_scene import CAMS, H, PipeScene, W, px, turned

from vision.detector import REFUSED_END_FACTOR, DetectorConfig, PipeDetection, PipeEngine
from vision.end_search import CameraFall, RimEnd, RimSearch
from vision.silhouette import Silhouette

ENDS = (-0.5, 0.5)  # the pipe's ends' axis coordinates (m) from its centre
SHORT = 0.06  # the colour region stops this short of each end (m): no end outline
SCENE = PipeScene(ENDS, (ENDS[0] + SHORT, ENDS[1] - SHORT), 60, 0.0)


def _pipe(yaw: float) -> tuple[np.ndarray, np.ndarray]:
    a = np.array([np.cos(yaw) * np.cos(0.1), np.sin(0.1), np.sin(yaw) * np.cos(0.1)])
    return np.array([0.1, 0.05, 1.5]), a / np.linalg.norm(a)


def _detect(
    yaw: float, turn_deg: float, seed: int, arm_over_end_in: int | None = None
) -> tuple[PipeDetection, np.ndarray, np.ndarray]:
    """The detector on a ``2+1`` scene: both edges of the left camera and one of the right
    drawn on the axis turned by ``turn_deg``, the pipe scores those of the true pipe; with
    ``arm_over_end_in``, that camera's arm mask a disc over the pipe's end at ``-a``."""
    p, a = _pipe(yaw)
    q, b = turned(p, a, turn_deg, ENDS[1])
    rng = np.random.default_rng(seed)
    sils: list[Silhouette | None] = [
        SCENE.view(p, a, CAMS[0][2], SCENE.edges(q, b, CAMS[0][2], (1, -1)), rng),
        SCENE.view(p, a, CAMS[1][2], SCENE.edges(q, b, CAMS[1][2], (1,)), rng),
    ]
    blocked: list[np.ndarray | None] = [None, None]
    if arm_over_end_in is not None:
        mask = np.zeros((H, W), np.uint8)
        centre = px((p + CAMS[arm_over_end_in][2] + ENDS[0] * a)[None, :])[0]
        cv2.circle(mask, (int(centre[0]), int(centre[1])), 45, 255, -1)
        blocked[arm_over_end_in] = mask
    engine = PipeEngine(DetectorConfig())
    return engine._fit(sils, CAMS, np.array([0.0, 1.0, 0.0]), None, blocked=blocked), p, a


def _axis_error_deg(det: PipeDetection, a: np.ndarray) -> float:
    assert det.axis_dir_cam is not None
    return float(np.degrees(np.arccos(min(1.0, abs(float(det.axis_dir_cam @ a))))))


def _without_the_refused_end(det: PipeDetection) -> float:
    """The confidence the same answer had with the refused end only dropped: its end factor
    that of one end taken (the end fit's own), no factor for the refusal."""
    f = det.quality["factors"]
    end_fit = f["end"] / max(np.exp(-(((det.quality["length_with_refused_end_m"] - 1.0) / 0.05) ** 2)), 1e-12)
    views = f["views"] / REFUSED_END_FACTOR ** det.quality["rim_ends_contradicted"]
    return float(end_fit * views * f["gravity"] * f["fit"] * f["radius"] * f["straight"] * f["geometry"])


@pytest.mark.parametrize(
    ("yaw", "turn", "seed", "contradicted"),
    [
        (0.0, 12.0, 0, True),  # the right camera places the end 2-3 cm off; the distance 6 cm short
        (0.3, -12.0, 0, True),  # the distance within 2 cm of the length: the camera's contradiction alone
        (0.6, 12.0, 0, False),  # no camera in view places it elsewhere: the distance alone (8 cm long)
        (0.0, -12.0, 1, True),
    ],
)
def test_a_refused_end_lowers_a_wrong_2_plus_1_axis_that_crosses_the_true_one_at_the_other_end(
    yaw: float, turn: float, seed: int, contradicted: bool
) -> None:
    det, _, a = _detect(yaw, turn, seed)
    q = det.quality
    assert q["views_used"] == "2+1"
    assert _axis_error_deg(det, a) > 5.0
    assert q["rim_search_ends"] == 1 and q["rim_ends_unconfirmed"] == 1  # one end taken, one refused
    assert (q["rim_ends_contradicted"] == 1) is contradicted
    assert _without_the_refused_end(det) > 0.7  # dropping the refused end alone leaves it confident
    assert det.confidence < 0.2
    assert "places the refused end elsewhere" in det.reason or "the end refused along the rim is" in det.reason


@pytest.mark.parametrize(("yaw", "turn", "seed"), [(0.3, 0.0, 2), (0.3, -3.0, 2), (0.6, 3.0, 2)])
def test_a_right_2_plus_1_axis_whose_end_is_faint_in_one_camera_keeps_its_confidence(
    yaw: float, turn: float, seed: int
) -> None:
    """One camera's own fall at the end stands out less than the confirmation asks (z under
    2) but its own best is at the end: the end is refused, nothing counts against the axis."""
    det, _, a = _detect(yaw, turn, seed)
    q = det.quality
    assert _axis_error_deg(det, a) < 5.0
    assert q["rim_search_ends"] == 1 and q["rim_ends_unconfirmed"] == 1
    assert q["rim_ends_contradicted"] == 0
    assert abs(q["length_with_refused_end_m"] - 1.0) < 0.02
    assert det.confidence > 0.8


@pytest.mark.parametrize(("yaw", "seed", "camera"), [(0.0, 0, 1), (0.3, 1, 0), (0.6, 0, 1)])
def test_an_end_the_arm_hides_from_one_camera_does_not_count_against_a_right_axis(
    yaw: float, seed: int, camera: int
) -> None:
    """The arm covers one end's rim in one camera: the other camera alone sees that end, so
    it is refused (as any end one camera cannot confirm), but the camera that cannot see it
    does not contradict it, and its distance from the taken end is the pipe's length."""
    det, p, a = _detect(yaw, 0.0, seed, arm_over_end_in=camera)
    q = det.quality
    assert q["rim_search_ends"] == 1 and q["rim_ends_unconfirmed"] == 1
    assert q["rim_ends_contradicted"] == 0
    assert abs(q["length_with_refused_end_m"] - 1.0) < 0.02
    assert det.end_cam is not None and np.linalg.norm(det.end_cam - (p + ENDS[1] * a)) < 0.015
    assert det.confidence > 0.8


def _end(per_camera: dict[int, CameraFall]) -> RimEnd:
    return RimEnd(0.5, 0.4, 0.4, 0.5, 3.0, 5.0, {}, per_camera)


def test_only_a_camera_in_view_that_places_the_end_elsewhere_contradicts_it() -> None:
    cfg = RimSearch()
    faint_here = CameraFall(0.4, 1.5, 0.003)  # its own best at the end, not standing out enough
    elsewhere = CameraFall(0.3, 2.5, 0.024)  # its own best 2.4 cm along the axis
    off_score = CameraFall(float("nan"), float("nan"), 0.02)  # its rim image there is off the pipe's score
    assert _end({0: CameraFall(0.8, 5.0, 0.0), 1: faint_here}).contradicted_by(cfg, (1,), set()) == []
    assert _end({0: CameraFall(0.8, 5.0, 0.0), 1: elsewhere}).contradicted_by(cfg, (1,), set()) == [1]
    assert _end({0: CameraFall(0.8, 5.0, 0.0), 1: off_score}).contradicted_by(cfg, (1,), set()) == [1]
    assert _end({0: CameraFall(0.8, 5.0, 0.0)}).contradicted_by(cfg, (1,), set()) == [1]  # no fall of its own
    # cut by the border or the arm there (or its region runs into them on that side): it cannot see the end
    assert _end({0: CameraFall(0.8, 5.0, 0.0), 1: elsewhere}).contradicted_by(cfg, (1,), {1}) == []
