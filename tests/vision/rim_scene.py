"""Synthetic two-camera scenes of a capped pipe whose end the rim search must find.

A capped pipe of radius :data:`RADIUS` is ray-cast into two ideal cameras 0.2 m apart
(:data:`CAMS`); its pipe score is the silhouette blurred under block noise (a very
turbid image after the restoration); its colour region stops short of the ends (no
end outline: the rim search's case); its straight edges are drawn as the tangents of
a given cylinder, the true one or one turned in depth (:func:`turned`). Used by the
tests of the rim end's confirmation and of a refused end as evidence.
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

from vision.calibration import CameraModel
from vision.silhouette import Limb, Score, Silhouette

W, H, F = 640, 480, 700.0
K = np.array([[F, 0.0, W / 2], [0.0, F, H / 2], [0.0, 0.0, 1.0]])
RADIUS = 0.05
CONTRAST = 12.0
CAMS = [
    (CameraModel(W, H, K, np.zeros(5), "left"), np.eye(3), np.zeros(3)),
    (CameraModel(W, H, K, np.zeros(5), "right"), np.eye(3), np.array([-0.2, 0.0, 0.0])),  # X_right = X_left + t
]


def px(X: np.ndarray) -> np.ndarray:
    """Pixels of camera-frame points (n, 3)."""
    return X[:, :2] / X[:, 2:3] * F + np.array([W / 2, H / 2])


def pipe_score(hit: np.ndarray, rng: np.random.Generator) -> Score:
    """The pipe score: ``CONTRAST`` on the pipe, 0 around it, blurred, under 8 x 8 px block
    noise and pixel noise of about a third of the contrast."""
    img = np.asarray(cv2.GaussianBlur(hit.astype(np.float32) * CONTRAST, (0, 0), 1.2), np.float32)
    blocks = rng.normal(0.0, 0.3 * CONTRAST, (H // 8 + 1, W // 8 + 1)).astype(np.float32)
    img += np.repeat(np.repeat(blocks, 8, axis=0), 8, axis=1)[:H, :W]
    img += rng.normal(0.0, 0.15 * CONTRAST, (H, W)).astype(np.float32)
    return Score(cv2.GaussianBlur(img, (0, 0), 1.0), 0, 0, CONTRAST, 3, 0.6)


def turned(p: np.ndarray, a: np.ndarray, deg: float, pivot_s: float) -> tuple[np.ndarray, np.ndarray]:
    """The axis (``p``, ``a``) turned by ``deg`` in depth about its point at ``pivot_s`` (m
    along it), within the plane through the left camera's centre and the axis (where the
    left camera's image of the axis stays put): it crosses the true axis there."""
    pivot = p + pivot_s * a
    k = np.cross(a, pivot)
    k /= np.linalg.norm(k)
    th = np.radians(deg)
    a2 = a * np.cos(th) + np.cross(k, a) * np.sin(th) + k * (k @ a) * (1 - np.cos(th))
    return pivot - pivot_s * a2, a2


@dataclass(frozen=True)
class PipeScene:
    """The pipe capped at ``ends`` (axis coordinates, m, from its point ``p``), its colour
    region from ``region[0]`` to ``region[1]`` along it, its edges sampled at ``samples``
    points of that span, ``inside`` an axis coordinate within the region."""

    ends: tuple[float, float]
    region: tuple[float, float]
    samples: int
    inside: float

    def hits(self, p: np.ndarray, a: np.ndarray) -> np.ndarray:
        """Per pixel of a camera at the origin: whether its ray meets the capped pipe
        (its side or a cap's disc)."""
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
        hit = np.isfinite(t) & (s >= self.ends[0]) & (s <= self.ends[1])
        for s_cap in self.ends:
            E = p + s_cap * a
            with np.errstate(divide="ignore", invalid="ignore", over="ignore"):  # rays parallel to the cap
                tc = (E @ a) / (d @ a)
            tc = np.where(np.abs(tc) < 1e6, tc, -1.0)  # NaN and far beyond the scene: no hit
            hit |= (tc > 0) & (np.linalg.norm(tc[..., None] * d - E, axis=-1) <= RADIUS)
        return hit

    def edges(self, p: np.ndarray, a: np.ndarray, t: np.ndarray, sides: tuple[int, ...]) -> list[Limb]:
        """The straight edges (tangent lines) ``sides`` of the cylinder (``p``, ``a``) in the
        camera at ``-t``, drawn along the colour region's span."""
        w = p + t - ((p + t) @ a) * a
        dist = float(np.linalg.norm(w))
        e, f = w / dist, np.cross(a, w / dist)
        sinb, cosb = RADIUS / dist, np.sqrt(1.0 - (RADIUS / dist) ** 2)
        s = np.linspace(self.region[0], self.region[1], self.samples)
        inside = px((p + t + self.inside * a)[None, :])[0]
        limbs = []
        for side in sides:
            m = -sinb * e + side * cosb * f
            pts = px(p + t + s[:, None] * a + RADIUS * m)
            c = pts.mean(axis=0)
            n = np.linalg.svd(pts - c)[2][1]
            line = np.array([n[0], n[1], -float(n @ c)])
            if line @ np.append(inside, 1.0) < 0:
                line = -line
            line_norm = np.array([line[0] * F, line[1] * F, line[0] * W / 2 + line[1] * H / 2 + line[2]])
            limbs.append(Limb(line, line_norm, 0.4, pts, pts[[0, -1]], 4.0, False, side, False))
        return limbs

    def view(
        self, p: np.ndarray, a: np.ndarray, t: np.ndarray, limbs: list[Limb], rng: np.random.Generator
    ) -> Silhouette:
        """A camera's silhouette: the colour region along the true pipe, ``limbs`` its edges."""
        tips = px(p + t + np.array(self.region)[:, None] * a)
        mid = tips.mean(axis=0)
        u = (tips[1] - tips[0]) / np.linalg.norm(tips[1] - tips[0])
        half = float(np.linalg.norm(tips[1] - tips[0])) / 2
        sil = Silhouette(20000, (0, 0, W, H), mid, u, 20.0, (-half, half), np.zeros((0, 2)), limbs, {})
        sil.score = pipe_score(self.hits(p + t, a), rng)
        return sil
