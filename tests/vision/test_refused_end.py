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

The scenes are a capped 1 m pipe ray-cast into two ideal cameras 0.2 m apart, both
ends in view, its pipe score the silhouette blurred under block noise (a very turbid
image after the restoration), and straight edges drawn as the tangents of a given
cylinder: the true one, or one turned in depth about the pipe's end at ``+a`` within
the plane through the left camera and the axis (where the left camera's image of the
axis stays put).
"""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from vision.calibration import CameraModel
from vision.detector import REFUSED_END_FACTOR, DetectorConfig, PipeDetection, PipeEngine
from vision.end_search import CameraFall, RimEnd, RimSearch
from vision.silhouette import Limb, Score, Silhouette

W, H, F = 640, 480, 700.0
K = np.array([[F, 0.0, W / 2], [0.0, F, H / 2], [0.0, 0.0, 1.0]])
RADIUS = 0.05
CONTRAST = 12.0
CAMS = [
    (CameraModel(W, H, K, np.zeros(5), "left"), np.eye(3), np.zeros(3)),
    (CameraModel(W, H, K, np.zeros(5), "right"), np.eye(3), np.array([-0.2, 0.0, 0.0])),  # X_right = X_left + t
]
ENDS = (-0.5, 0.5)  # the pipe's ends' axis coordinates (m) from its centre
SHORT = 0.06  # the colour region stops this short of each end (m): no end outline


def _pipe(yaw: float) -> tuple[np.ndarray, np.ndarray]:
    a = np.array([np.cos(yaw) * np.cos(0.1), np.sin(0.1), np.sin(yaw) * np.cos(0.1)])
    return np.array([0.1, 0.05, 1.5]), a / np.linalg.norm(a)


def _hits(p: np.ndarray, a: np.ndarray) -> np.ndarray:
    """Per pixel of a camera at the origin: whether its ray meets the capped pipe from
    ``ENDS[0]`` to ``ENDS[1]`` along ``a`` from ``p`` (its side or a cap's disc)."""
    v, u = np.mgrid[0:H, 0:W].astype(float)
    d = np.stack([(u - W / 2) / F, (v - H / 2) / F, np.ones_like(u)], axis=-1)
    d /= np.linalg.norm(d, axis=-1, keepdims=True)
    dp = d - (d @ a)[..., None] * a
    wp = -p + (p @ a) * a
    A, B, C = np.sum(dp * dp, axis=-1), 2.0 * dp @ wp, wp @ wp - RADIUS**2
    disc = B * B - 4 * A * C
    t = np.where(disc >= 0, (-B - np.sqrt(np.maximum(disc, 0))) / (2 * A), np.inf)
    with np.errstate(invalid="ignore"):
        s = (-p @ a) + t * (d @ a)
    hit = np.isfinite(t) & (s >= ENDS[0]) & (s <= ENDS[1])
    for s_cap in ENDS:
        E = p + s_cap * a
        with np.errstate(divide="ignore", invalid="ignore"):  # rays parallel to the cap
            tc = (E @ a) / (d @ a)
            hit |= (tc > 0) & (np.linalg.norm(tc[..., None] * d - E, axis=-1) <= RADIUS)
    return hit


def _score(hit: np.ndarray, rng: np.random.Generator) -> Score:
    """The pipe score: ``CONTRAST`` on the pipe, 0 around it, blurred, under 8 x 8 px block
    noise and pixel noise of about a third of the contrast."""
    img = np.asarray(cv2.GaussianBlur(hit.astype(np.float32) * CONTRAST, (0, 0), 1.2), np.float32)
    blocks = rng.normal(0.0, 0.3 * CONTRAST, (H // 8 + 1, W // 8 + 1)).astype(np.float32)
    img += np.repeat(np.repeat(blocks, 8, axis=0), 8, axis=1)[:H, :W]
    img += rng.normal(0.0, 0.15 * CONTRAST, (H, W)).astype(np.float32)
    return Score(cv2.GaussianBlur(img, (0, 0), 1.0), 0, 0, CONTRAST, 3, 0.6)


def _px(X: np.ndarray) -> np.ndarray:
    return X[:, :2] / X[:, 2:3] * F + np.array([W / 2, H / 2])


def _edges(p: np.ndarray, a: np.ndarray, t: np.ndarray, sides: tuple[int, ...]) -> list[Limb]:
    """The straight edges (tangent lines) ``sides`` of the cylinder (``p``, ``a``) in the
    camera at ``-t``, drawn along the part of the pipe the colour region holds."""
    w = p + t - ((p + t) @ a) * a
    dist = float(np.linalg.norm(w))
    e, f = w / dist, np.cross(a, w / dist)
    sinb, cosb = RADIUS / dist, np.sqrt(1.0 - (RADIUS / dist) ** 2)
    s = np.linspace(ENDS[0] + SHORT, ENDS[1] - SHORT, 60)
    inside = _px((p + t)[None, :])[0]
    limbs = []
    for side in sides:
        m = -sinb * e + side * cosb * f
        pts = _px(p + t + s[:, None] * a + RADIUS * m)
        c = pts.mean(axis=0)
        n = np.linalg.svd(pts - c)[2][1]
        line = np.array([n[0], n[1], -float(n @ c)])
        if line @ np.append(inside, 1.0) < 0:
            line = -line
        line_norm = np.array([line[0] * F, line[1] * F, line[0] * W / 2 + line[1] * H / 2 + line[2]])
        limbs.append(Limb(line, line_norm, 0.4, pts, pts[[0, -1]], 4.0, False, side, False))
    return limbs


def _view(p: np.ndarray, a: np.ndarray, t: np.ndarray, limbs: list[Limb], rng: np.random.Generator) -> Silhouette:
    """A camera's silhouette: the colour region along the true pipe, ``SHORT`` short of
    both ends (no end outline: the rim search's case), ``limbs`` its edges."""
    tips = _px(p + t + np.array([ENDS[0] + SHORT, ENDS[1] - SHORT])[:, None] * a)
    mid = tips.mean(axis=0)
    u = (tips[1] - tips[0]) / np.linalg.norm(tips[1] - tips[0])
    half = float(np.linalg.norm(tips[1] - tips[0])) / 2
    sil = Silhouette(20000, (0, 0, W, H), mid, u, 20.0, (-half, half), np.zeros((0, 2)), limbs, {})
    sil.score = _score(_hits(p + t, a), rng)
    return sil


def _turned(p: np.ndarray, a: np.ndarray, deg: float) -> tuple[np.ndarray, np.ndarray]:
    """The axis turned by ``deg`` in depth about the pipe's end at ``+a``, within the plane
    through the left camera's centre and the axis: it crosses the true axis at that end."""
    pivot = p + ENDS[1] * a
    k = np.cross(a, pivot)
    k /= np.linalg.norm(k)
    th = np.radians(deg)
    a2 = a * np.cos(th) + np.cross(k, a) * np.sin(th) + k * (k @ a) * (1 - np.cos(th))
    return pivot - ENDS[1] * a2, a2


def _detect(
    yaw: float, turn_deg: float, seed: int, arm_over_end_in: int | None = None
) -> tuple[PipeDetection, np.ndarray, np.ndarray]:
    """The detector on a ``2+1`` scene: both edges of the left camera and one of the right
    drawn on the axis turned by ``turn_deg``, the pipe scores those of the true pipe; with
    ``arm_over_end_in``, that camera's arm mask a disc over the pipe's end at ``-a``."""
    p, a = _pipe(yaw)
    q, b = _turned(p, a, turn_deg)
    rng = np.random.default_rng(seed)
    sils: list[Silhouette | None] = [
        _view(p, a, CAMS[0][2], _edges(q, b, CAMS[0][2], (1, -1)), rng),
        _view(p, a, CAMS[1][2], _edges(q, b, CAMS[1][2], (1,)), rng),
    ]
    blocked: list[np.ndarray | None] = [None, None]
    if arm_over_end_in is not None:
        mask = np.zeros((H, W), np.uint8)
        centre = _px((p + CAMS[arm_over_end_in][2] + ENDS[0] * a)[None, :])[0]
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
