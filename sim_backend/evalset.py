"""An evaluation set for the pipe detector, made independently of the simulator's renderer.

The detector is developed on :mod:`sim_backend.render` images. To say how it
does on images it was not tuned on, this module renders stereo pairs with an
image formation of its own: it imports nothing from ``render.py`` /
``render_optics.py`` and differs from them in every stage.

* **Rig**: 1292 x 964 pixels (the Mako G-125's), focal length 1170 px (a 4.4 mm
  lens on 3.75 um pixels), principal point off the centre, stronger barrel
  distortion (``k1 = -0.14``, tangential terms), the right camera 0.2 m away and
  0.3-0.5 deg askew. The detector gets this rig as ROS ``camera_info`` files,
  as a new user would (:func:`write_rig_files`).
* **Scene** (world: z up, floor at z = 0, the water surface at the scene's
  depth): a procedural floor (square tiles of random size and colour, painted or
  bare concrete; value noise, rust and algae stains) instead of the simulator's
  regular tiles, the pipe (a capped cylinder with a dirt texture and a little
  gloss), optionally an arm (dark capsules from beside the camera to above the
  pipe, with a gripper ball).
* **Light**: daylight from the surface split into a direct (sun) part casting
  soft shadows (the pipe's and the arm's on the floor) and a diffuse (sky) part
  weighted by the surface's tilt, plus light bounced off the floor; the direct
  share falls with turbidity. Optional lamps beside the camera: a beam with an
  inverse-square fall-off, and their light scattered back into the camera
  integrated along each line of sight (single scattering, at 1/8 resolution).
* **Water**: per-channel beam attenuation ``c = a_water + a_cdom + b``: pure
  water's absorption, dissolved matter absorbing blue in turbid water, and
  particle scattering ``b`` from the visibility (``c ~ 4.8 / V``, Zaneveld &
  Pegau 2003). The line of sight: ``I = J exp(-c d) + B_inf (1 - exp(-c d))``
  with ``B_inf = (b / c) * 0.2 * daylight`` at the camera's depth (the veil of
  scattered daylight; 0.2 is an assumed phase-function share) + lamp backscatter.
* **Camera**: white balance by one of three presets (fixed daylight gains: the
  water's cast left in; a grey card on the floor; the camera's own grey-world
  auto white balance at partial strength), each with a random error of +-12 %
  per channel; auto exposure with an error; Gaussian optical blur; a motion-blur
  line kernel; a Bayer RGGB mosaic with shot noise (10 000 e- full well) and read
  noise, bilinear demosaicing; a gamma of 1/2.2; JPEG compression (quality
  55-95) or none.

Every nuisance factor is drawn from its own random stream (:func:`make_view`):
lighting, colour cast, lamps, noise, compression and motion blur vary
independently of the geometry and of one another. Views: ``pipe`` (one or both
ends in view), ``arm`` (the arm hides part of the pipe; the arm mask, the
arm's silhouette dilated by 4 px and shifted by up to 2 px as a reprojection
error, is given), ``partial`` (the pipe crosses the image border), ``nopipe``
(no pipe in either image).

Splits: ``eval`` (the set reported in docs/vision.md), ``tune`` and ``tune2``
(development: the same plan of conditions, other base seeds). No two splits
share a seed: each split's base seed is the first entry of every view's seed
sequence (:data:`SPLIT_SEEDS`).

:func:`pipe_contrast` measures, from a view's truth, how far the pipe's colour
stands from the floor beside it in the left image: what the benchmark's
detection-limit table bins the views by.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from vision.calibration import CameraModel, StereoCalibration, undistort_points

F32 = np.float32

#: Image size and lens of the evaluation rig (the Mako G-125 behind a 4.4 mm lens).
WIDTH, HEIGHT = 1292, 964
FOCAL_PX = 1170.0
BASELINE_M = 0.2

#: Pure water's absorption (1/m) for broad R, G, B camera bands (Pope & Fry 1997, band averages).
A_WATER_RGB = np.array([0.35, 0.065, 0.018])
#: Visibility of a dark target in attenuation lengths (Zaneveld & Pegau 2003).
VIS_LENGTHS = 4.8
#: Waters: visibility range (m) and the dissolved matter's blue absorption range (1/m).
WATERS: dict[str, dict[str, tuple[float, float]]] = {
    "clear": {"visibility_m": (12.0, 25.0), "cdom_blue": (0.0, 0.03)},
    "slightly_turbid": {"visibility_m": (3.5, 6.0), "cdom_blue": (0.05, 0.2)},
    "very_turbid": {"visibility_m": (1.2, 2.0), "cdom_blue": (0.15, 0.5)},
}
#: Pipe: radius and length (m), as the MARIS pipe.
PIPE_RADIUS = 0.05
PIPE_LENGTH = 1.0
#: Base seed of each split (the first entry of every view's seed sequence, so
#: no two splits share a view's streams): ``eval`` is reported, never tuned
#: on; ``tune`` and ``tune2`` are for development.
SPLIT_SEEDS: dict[str, int] = {"eval": 420_000, "tune": 910_000, "tune2": 655_000}


# --------------------------------------------------------------------------- rig


def eval_rig() -> StereoCalibration:
    """The evaluation rig's true calibration (see the module doc)."""
    K1 = np.array([[FOCAL_PX, 0.0, 651.3], [0.0, FOCAL_PX * 1.0008, 478.6], [0.0, 0.0, 1.0]])
    K2 = np.array([[FOCAL_PX * 0.9991, 0.0, 640.2], [0.0, FOCAL_PX * 0.9997, 485.1], [0.0, 0.0, 1.0]])
    D1 = np.array([-0.142, 0.061, 0.0006, -0.0004, -0.011])
    D2 = np.array([-0.138, 0.057, -0.0003, 0.0005, -0.009])
    r = np.radians([0.31, -0.42, 0.18])
    R = _rot(r)
    T = -R @ np.array([BASELINE_M, 0.0012, -0.0008])
    return StereoCalibration(
        CameraModel(WIDTH, HEIGHT, K1, D1, "left"), CameraModel(WIDTH, HEIGHT, K2, D2, "right"), R, T, "evaluation rig"
    )


def _rot(rvec: np.ndarray) -> np.ndarray:
    th = float(np.linalg.norm(rvec))
    if th < 1e-12:
        return np.eye(3)
    k = rvec / th
    Kx = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
    return np.eye(3) + math.sin(th) * Kx + (1 - math.cos(th)) * Kx @ Kx


def write_rig_files(calib: StereoCalibration, folder: Path) -> tuple[Path, Path]:
    """The rig as two ROS ``camera_info`` YAML files (left, right), as ROS's
    camera_calibration writes them (rectification from OpenCV's stereoRectify)."""
    import cv2
    import yaml

    R1, R2, P1, P2, _, _, _ = cv2.stereoRectify(
        calib.left.K, calib.left.D, calib.right.K, calib.right.D, calib.left.size, calib.R, calib.T.reshape(3, 1)
    )
    folder.mkdir(parents=True, exist_ok=True)
    out = []
    for name, cam, Rr, P in (("left", calib.left, R1, P1), ("right", calib.right, R2, P2)):

        def mat(m: np.ndarray) -> dict:
            return {"rows": int(m.shape[0]), "cols": int(m.shape[1]), "data": [float(x) for x in m.reshape(-1)]}

        doc = {
            "image_width": cam.width,
            "image_height": cam.height,
            "camera_name": f"eval_{name}",
            "camera_matrix": mat(cam.K),
            "distortion_model": "plumb_bob",
            "distortion_coefficients": mat(cam.D.reshape(1, -1)),
            "rectification_matrix": mat(Rr),
            "projection_matrix": mat(P),
        }
        p = folder / f"{name}.yaml"
        p.write_text(yaml.safe_dump(doc, sort_keys=False))
        out.append(p)
    return out[0], out[1]


class _RayCache:
    """Unit rays (camera frame) of every pixel of a camera, float32 (N, 3)."""

    def __init__(self, cam: CameraModel, step: int = 1):
        h, w = cam.height, cam.width
        v, u = np.mgrid[0:h:step, 0:w:step]
        xy = undistort_points(np.stack([u.ravel(), v.ravel()], axis=1).astype(np.float64), cam)
        d = np.column_stack([xy, np.ones(len(xy))])
        d /= np.linalg.norm(d, axis=1, keepdims=True)
        self.d = d.astype(F32)
        self.shape = v.shape
        self.lo = xy.min(axis=0)
        self.hi = xy.max(axis=0)


_RAYS: dict[tuple, _RayCache] = {}


def _rays(cam: CameraModel, step: int = 1) -> _RayCache:
    key = (cam.width, cam.height, tuple(cam.K.ravel()), tuple(cam.D.ravel()), step)
    if key not in _RAYS:
        _RAYS[key] = _RayCache(cam, step)
    return _RAYS[key]


# --------------------------------------------------------------------------- scene


@dataclass
class Water:
    """Beam attenuation ``c`` and scattering ``b`` (1/m), RGB."""

    c: np.ndarray
    b: float
    visibility_m: float


@dataclass
class Lighting:
    """Daylight at the surface (relative), sun direction (unit, world, pointing to the sun),
    direct share, lamp power (0: off), floor bounce albedo."""

    daylight: float
    sun: np.ndarray
    direct_share: float
    lamp_power: float


@dataclass
class CameraSettings:
    """White balance mode and gains error, exposure bias, blur (px), motion blur
    (length px, angle rad), analog gain ceiling, JPEG quality (0: lossless)."""

    wb_mode: str
    wb_error: np.ndarray
    exposure_bias: float
    optical_blur_px: float
    motion_px: float
    motion_angle: float
    jpeg_quality: int
    read_noise_e: float


@dataclass
class Floor:
    """Procedural floor: kind (tiles, concrete, painted), tile size (m), base
    colours (RGB albedo), stains [(x, y, radius, rgb albedo multiplier)]."""

    kind: str
    tile_m: float
    colours: np.ndarray
    grout: np.ndarray
    stains: list[tuple[float, float, float, np.ndarray]]
    seed: int


@dataclass
class View:
    """One evaluation pair and its truth (left camera frame, OpenCV optical axes, m)."""

    name: str
    kind: str  # pipe | arm | partial | nopipe
    water_name: str
    range_m: float
    left: np.ndarray
    right: np.ndarray
    #: pipe centre pose (4, 4) in the left camera frame, x along the axis; None: no pipe
    cam_T_pipe: np.ndarray | None
    #: end centres (2, 3), left camera frame
    ends_cam: np.ndarray | None
    #: which ends (0, 1) are fully in the left image and not hidden
    ends_visible: tuple[int, ...]
    gravity_cam: np.ndarray
    arm_masks: tuple[np.ndarray, np.ndarray] | None
    params: dict[str, Any] = field(default_factory=dict)
    #: the pipe's visible pixels in the left image (diagnostics only; never given to the detector)
    pipe_left: np.ndarray | None = None


def _dot(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Row-wise dot products of two (N, 3) arrays."""
    return np.einsum("ij,ij->i", a, b)


def _value_noise(x: np.ndarray, y: np.ndarray, grid: np.ndarray, scale: float) -> np.ndarray:
    """Smooth noise in [-1, 1] at points (x, y) (m), lattice spacing ``scale`` (m)."""
    n = grid.shape[0]
    gx, gy = x / F32(scale), y / F32(scale)
    ix, iy = np.floor(gx), np.floor(gy)
    fx, fy = gx - ix, gy - iy
    fx = fx * fx * (3 - 2 * fx)
    fy = fy * fy * (3 - 2 * fy)
    i0, j0 = ix.astype(np.int64) % n, iy.astype(np.int64) % n
    i1, j1 = (i0 + 1) % n, (j0 + 1) % n
    a = grid[i0, j0] * (1 - fx) + grid[i1, j0] * fx
    b = grid[i0, j1] * (1 - fx) + grid[i1, j1] * fx
    return (a * (1 - fy) + b * fy).astype(F32)


def _floor_albedo(floor: Floor, x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """RGB albedo (N, 3) of floor points (m)."""
    rng = np.random.default_rng(floor.seed)
    grids = [rng.uniform(-1, 1, (97, 97)).astype(F32) for _ in range(3)]
    noise = 0.55 * _value_noise(x, y, grids[0], 0.9) + 0.3 * _value_noise(x, y, grids[1], 0.21)
    noise += 0.15 * _value_noise(x, y, grids[2], 0.037)
    if floor.kind == "tiles":
        t = F32(floor.tile_m)
        ix, iy = np.floor(x / t).astype(np.int64), np.floor(y / t).astype(np.int64)
        pick = ((ix * 73856093) ^ (iy * 19349663)) % len(floor.colours)
        base = floor.colours[pick]
        jitter = (((ix * 83492791) ^ (iy * 2654435761)) % 1000).astype(F32) / 1000.0 - 0.5
        base = base * (1.0 + 0.08 * jitter)[:, None]
        gw = F32(0.006 + 0.004 * (floor.seed % 3))
        fx, fy = x - ix * t, y - iy * t
        grout = (fx < gw) | (fy < gw)
        alb = np.where(grout[:, None], floor.grout[None, :], base) * (1.0 + 0.06 * noise)[:, None]
    else:
        amp = 0.22 if floor.kind == "concrete" else 0.1
        alb = floor.colours[0][None, :] * (1.0 + amp * noise)[:, None]
    for sx, sy, sr, mult in floor.stains:
        d2 = (x - F32(sx)) ** 2 + (y - F32(sy)) ** 2
        w = np.exp(-d2 / F32(sr * sr)) * (0.75 + 0.25 * noise)
        alb = alb * (1.0 + w[:, None] * (mult[None, :] - 1.0))
    return np.clip(alb, 0.01, 0.95).astype(F32)


@dataclass
class Capsule:
    """A cylinder from ``a`` to ``b`` (world, m) of radius ``r``, with ball ends."""

    a: np.ndarray
    b: np.ndarray
    r: float


def _capsule_hit(o: np.ndarray, d: np.ndarray, cap: Capsule) -> np.ndarray:
    """Nearest hit distance (inf: none) of rays ``o + t d`` (d unit, (N, 3)) with a capsule."""
    ab = cap.b - cap.a
    L = float(np.linalg.norm(ab))
    ax = (ab / L).astype(F32)
    w = (o - cap.a).astype(F32)
    da = d @ ax
    wa = F32(w @ ax)
    dd = d - da[:, None] * ax[None, :]
    ww = w - wa * ax
    A = _dot(dd, dd)
    B = 2.0 * (dd @ ww)
    C = F32(ww @ ww - cap.r * cap.r)
    disc = B * B - 4 * A * C
    with np.errstate(invalid="ignore", divide="ignore"):
        t = (-B - np.sqrt(np.maximum(disc, 0))) / (2 * A)
        s = wa + t * da
        t = np.where((disc >= 0) & (t > 0) & (s >= 0) & (s <= L), t, np.inf)
    for c in (cap.a, cap.b):
        t = np.minimum(t, _sphere_hit(o, d, c, cap.r))
    return t.astype(F32)


def _sphere_hit(o: np.ndarray, d: np.ndarray, c: np.ndarray, r: float) -> np.ndarray:
    w = (o - c).astype(F32)
    b = d @ w
    disc = b * b - F32(w @ w - r * r)
    with np.errstate(invalid="ignore"):
        t = -b - np.sqrt(np.maximum(disc, 0))
    return np.where((disc >= 0) & (t > 0), t, np.inf).astype(F32)


def _pipe_hit(o: np.ndarray, d: np.ndarray, centre: np.ndarray, axis: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Nearest hit (inf: none) of rays with the capped pipe, and the normals (N, 3) there."""
    r, h = PIPE_RADIUS, 0.5 * PIPE_LENGTH
    ax = axis.astype(F32)
    w = (o - centre).astype(F32)
    da = d @ ax
    wa = F32(w @ ax)
    dd = d - da[:, None] * ax[None, :]
    ww = w - wa * ax
    A = _dot(dd, dd)
    B = 2.0 * (dd @ ww)
    C = F32(ww @ ww - r * r)
    disc = B * B - 4 * A * C
    with np.errstate(invalid="ignore", divide="ignore"):
        t = (-B - np.sqrt(np.maximum(disc, 0))) / (2 * A)
        s = wa + t * da
        t = np.where((disc >= 0) & (t > 0) & (np.abs(s) <= h), t, np.inf)
        cap = np.zeros(len(d), np.int8)
        for sign in (-1, 1):
            tc = (F32(sign * h) - wa) / da
            p = w[None, :] + tc[:, None] * d - F32(sign * h) * ax[None, :]
            ok = (tc > 0) & (_dot(p, p) <= r * r) & (tc < t)
            t = np.where(ok, tc, t)
            cap = np.where(ok, np.int8(sign), cap)
    tt = np.where(np.isfinite(t), t, 0)
    P = w[None, :] + tt[:, None] * d
    radial = P - (P @ ax)[:, None] * ax[None, :]
    n = radial / F32(r)
    n = np.where(cap[:, None] != 0, cap[:, None].astype(F32) * ax[None, :], n)
    return t.astype(F32), n.astype(F32)


def _segment_ray_distance(P: np.ndarray, L: np.ndarray, a: np.ndarray, b: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """For rays ``P + s L`` (P (N, 3), L unit (3,)) and segment a-b: the closest
    distance and the ray parameter s there (s > 0: towards the light)."""
    u = (b - a).astype(F32)
    Lu = F32(L @ u)
    uu = F32(u @ u)
    w0 = P - a.astype(F32)[None, :]
    LL = F32(1.0)
    den = LL * uu - Lu * Lu
    wL = w0 @ L.astype(F32)
    wu = w0 @ u
    with np.errstate(invalid="ignore", divide="ignore"):
        s = (Lu * wu - uu * wL) / max(den, 1e-9)
        q = np.clip((wu + s * Lu) / uu, 0, 1)
        s = q * Lu - wL  # the ray parameter closest to the clipped segment point
    diff = w0 + s[:, None] * L.astype(F32)[None, :] - q[:, None] * u[None, :]
    return np.sqrt(_dot(diff, diff)), s


@dataclass
class Scene:
    """Geometry, water and light of one view."""

    depth_m: float
    floor: Floor
    water: Water
    light: Lighting
    pipe_centre: np.ndarray | None
    pipe_axis: np.ndarray | None
    pipe_albedo: np.ndarray
    pipe_dirt_seed: int
    arm: list[Capsule]
    hand: tuple[np.ndarray, float] | None


def _shade(
    scene: Scene, X: np.ndarray, n: np.ndarray, albedo: np.ndarray, cam_o: np.ndarray, cam_R: np.ndarray, gloss: float
) -> np.ndarray:
    """Radiance (N, 3) leaving surface points X (world) with normals n towards the camera."""
    lt, wt = scene.light, scene.water
    kd = (A_WATER_RGB + np.array([0.0, 0.0, 0.0]) + 0.3 * wt.b).astype(F32)  # diffuse attenuation
    depth_below = np.maximum(F32(scene.depth_m) - X[:, 2], 0)
    E = F32(lt.daylight) * np.exp(-depth_below[:, None] * kd[None, :])
    nz = n[:, 2]
    sky = (1.0 - lt.direct_share) * (0.5 + 0.5 * nz)
    bounce = 0.35 * 0.5 * (1.0 - nz) * (1.0 - lt.direct_share * 0.5)
    sun_cos = np.maximum(n @ lt.sun.astype(F32), 0)
    shadow = _shadow(scene, X)
    irr = E * (sky + bounce + lt.direct_share * sun_cos * shadow)[:, None]
    spec = np.zeros(len(X), F32)
    view = cam_o.astype(F32)[None, :] - X
    dist = np.sqrt(_dot(view, view))
    vdir = view / np.maximum(dist, 1e-6)[:, None]
    if gloss > 0:
        hv = lt.sun.astype(F32)[None, :] + vdir
        hv /= np.maximum(np.linalg.norm(hv, axis=1, keepdims=True), 1e-6)
        spec += F32(gloss * lt.direct_share) * np.maximum(_dot(n, hv), 0) ** 40 * shadow
    if lt.lamp_power > 0:
        cbar = F32(float(wt.c.mean()))
        for side in (-0.25, 0.25):
            Lp = cam_o + cam_R @ np.array([side, -0.08, 0.0])
            fwd = cam_R[:, 2].astype(F32)
            v = Lp.astype(F32)[None, :] - X
            dl = np.sqrt(_dot(v, v))
            ldir = v / np.maximum(dl, 1e-6)[:, None]
            beam = np.clip(-(ldir @ fwd), 0, 1) ** 6
            inc = np.maximum(_dot(n, ldir), 0)
            lamp = F32(lt.lamp_power) * beam * inc / np.maximum(dl * dl, 0.04) * np.exp(-cbar * dl)
            irr = irr + lamp[:, None] * np.ones(3, F32)[None, :]
            if gloss > 0:
                hv = ldir + vdir
                hv /= np.maximum(np.linalg.norm(hv, axis=1, keepdims=True), 1e-6)
                spec += F32(gloss) * lamp * np.maximum(_dot(n, hv), 0) ** 40
    return (albedo * irr + spec[:, None] * 0.6).astype(F32)


def _shadow(scene: Scene, X: np.ndarray) -> np.ndarray:
    """Direct-light visibility (0..1) of points X, soft: the pipe and the arm cast penumbrae."""
    vis = np.ones(len(X), F32)
    sun = scene.light.sun
    blockers: list[tuple[np.ndarray, np.ndarray, float]] = []
    if scene.pipe_centre is not None and scene.pipe_axis is not None:
        h = 0.5 * PIPE_LENGTH * scene.pipe_axis
        blockers.append((scene.pipe_centre - h, scene.pipe_centre + h, PIPE_RADIUS))
    blockers += [(c.a, c.b, c.r) for c in scene.arm]
    if scene.hand is not None:
        blockers.append((scene.hand[0], scene.hand[0] + 1e-4, scene.hand[1]))
    spread = F32(0.06 + 0.5 * min(scene.water.b, 1.0) * 0.2)  # penumbra per metre of distance
    low = X[:, 2] < 0.002  # floor points: test only those inside each blocker's footprint
    for a, b, r in blockers:
        ends = np.array([a, b])
        foot = ends[:, :2] - (ends[:, 2:3] / sun[2]) * sun[None, :2]  # the ends' shadows on the floor
        reach = r / max(sun[2], 0.2) + float(spread) * float(ends[:, 2].max()) / max(sun[2], 0.2) + 0.02
        lo, hi = (
            np.minimum(foot.min(axis=0), ends[:, :2].min(axis=0)) - reach,
            np.maximum(foot.max(axis=0), ends[:, :2].max(axis=0)) + reach,
        )
        near = ~low | ((X[:, 0] >= lo[0]) & (X[:, 0] <= hi[0]) & (X[:, 1] >= lo[1]) & (X[:, 1] <= hi[1]))
        idx = np.nonzero(near)[0]
        if len(idx) == 0:
            continue
        dist, s = _segment_ray_distance(X[idx], sun, a, b)
        pen = np.maximum(spread * s, 0.004)
        occ = np.clip((F32(r) - dist) / pen + 0.5, 0, 1) * (s > 0.005)
        vis[idx] *= 1.0 - 0.92 * occ
    return vis


def _render_linear(scene: Scene, cam: CameraModel, wTc: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Linear radiance image (H, W, 3) RGB seen by ``cam`` at pose ``wTc``, the arm's
    silhouette (H, W) bool and the pipe's silhouette (H, W) bool."""
    rays = _rays(cam)
    R, o = wTc[:3, :3], wTc[:3, 3]
    d = rays.d @ R.T.astype(F32)
    N = len(d)
    # floor
    with np.errstate(divide="ignore", invalid="ignore"):
        t_floor = np.where(d[:, 2] < -1e-6, F32(-o[2]) / d[:, 2], np.inf).astype(F32)
    t_pipe, n_pipe = np.full(N, np.inf, F32), np.zeros((N, 3), F32)
    if scene.pipe_centre is not None and scene.pipe_axis is not None:
        h = 0.5 * PIPE_LENGTH * scene.pipe_axis
        idx = _box_pixels(cam, wTc, np.array([scene.pipe_centre - h, scene.pipe_centre + h]), PIPE_RADIUS)
        t_pipe[idx], n_pipe[idx] = _pipe_hit(o, d[idx], scene.pipe_centre, scene.pipe_axis)
    t_arm = np.full(N, np.inf, F32)
    for cap in scene.arm:
        idx = _box_pixels(cam, wTc, np.array([cap.a, cap.b]), cap.r)
        t_arm[idx] = np.minimum(t_arm[idx], _capsule_hit(o, d[idx], cap))
    if scene.hand is not None:
        idx = _box_pixels(cam, wTc, scene.hand[0][None, :], scene.hand[1])
        t_arm[idx] = np.minimum(t_arm[idx], _sphere_hit(o, d[idx], scene.hand[0], scene.hand[1]))
    t = np.minimum(np.minimum(t_floor, t_pipe), t_arm)
    which = np.where(t_arm <= t, 2, np.where(t_pipe <= t, 1, 0))
    which = np.where(np.isfinite(t), which, 3)
    rad = np.zeros((N, 3), F32)
    for k in range(3):
        sel = np.nonzero(which == k)[0]
        if len(sel) == 0:
            continue
        X = o.astype(F32)[None, :] + t[sel, None] * d[sel]
        if k == 0:
            n = np.tile(np.array([0, 0, 1], F32), (len(sel), 1))
            alb = _floor_albedo(scene.floor, X[:, 0], X[:, 1])
            alb *= _ambient_occlusion(scene, X)[:, None]
            rad[sel] = _shade(scene, X, n, alb, o, R, 0.0)
        elif k == 1:
            n = n_pipe[sel]
            rng = np.random.default_rng(scene.pipe_dirt_seed)
            grid = rng.uniform(-1, 1, (61, 61)).astype(F32)
            assert scene.pipe_centre is not None and scene.pipe_axis is not None
            s = (X - scene.pipe_centre.astype(F32)) @ scene.pipe_axis.astype(F32)
            ang = np.arctan2(n[:, 2], n[:, 0] + n[:, 1])
            dirt = 1.0 + 0.09 * _value_noise(s, ang * 0.05, grid, 0.07)
            alb = scene.pipe_albedo.astype(F32)[None, :] * dirt[:, None]
            rad[sel] = _shade(scene, X, n, alb, o, R, 0.25)
        else:
            n = _capsule_normals(scene, X)
            alb = np.tile(np.array([0.07, 0.07, 0.08], F32), (len(sel), 1))
            rad[sel] = _shade(scene, X, n, alb, o, R, 0.5)
    c = scene.water.c.astype(F32)
    tt = np.where(np.isfinite(t), t, F32(100.0))
    tr = np.exp(-tt[:, None] * c[None, :])
    kd = (A_WATER_RGB + 0.3 * scene.water.b).astype(F32)
    amb_cam = F32(scene.light.daylight) * np.exp(-F32(max(scene.depth_m - o[2], 0.0)) * kd)
    b_inf = (F32(scene.water.b) / c) * F32(0.2) * amb_cam
    img = rad * tr + b_inf[None, :] * (1 - tr)
    img = img.reshape(cam.height, cam.width, 3)
    if scene.light.lamp_power > 0:
        img += _lamp_backscatter(scene, cam, wTc)
    return img, (which == 2).reshape(cam.height, cam.width), (which == 1).reshape(cam.height, cam.width)


_CUBE = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)], dtype=float)


def _box_pixels(cam: CameraModel, wTc: np.ndarray, pts_w: np.ndarray, r: float, margin: int = 4) -> np.ndarray:
    """Flat indices of the pixels that may see an object inside the cubes of half
    size ``r`` around ``pts_w`` (world); every pixel if part of it is behind the camera."""
    hull = (pts_w[:, None, :] + r * _CUBE[None]).reshape(-1, 3)
    Xc = (hull - wTc[:3, 3]) @ wTc[:3, :3]
    if np.any(Xc[:, 2] < 0.05):
        return np.arange(cam.width * cam.height)
    rays = _rays(cam)
    xy = np.clip(Xc[:, :2] / Xc[:, 2:3], rays.lo - 0.02, rays.hi + 0.02)  # beyond the view the lens model folds
    # the box of the normalized points (and its edge midpoints) through the distortion
    x0, y0 = xy.min(axis=0)
    x1, y1 = xy.max(axis=0)
    gx, gy = np.meshgrid(np.linspace(x0, x1, 5), np.linspace(y0, y1, 5))
    grid = np.column_stack([gx.ravel(), gy.ravel(), np.ones(gx.size)])
    uv = _project(cam, grid)
    c0, r0 = np.floor(uv.min(axis=0)).astype(int) - margin
    c1, r1 = np.ceil(uv.max(axis=0)).astype(int) + margin + 1
    c0, r0, c1, r1 = max(c0, 0), max(r0, 0), min(c1, cam.width), min(r1, cam.height)
    if c1 <= c0 or r1 <= r0:
        return np.zeros(0, np.int64)
    return (np.arange(r0, r1)[:, None] * cam.width + np.arange(c0, c1)[None, :]).ravel()


def _capsule_normals(scene: Scene, X: np.ndarray) -> np.ndarray:
    best = np.full(len(X), np.inf, F32)
    out = np.zeros_like(X)
    caps = [(c.a, c.b, c.r) for c in scene.arm]
    if scene.hand is not None:
        caps.append((scene.hand[0], scene.hand[0], scene.hand[1]))
    for a, b, r in caps:
        u = (b - a).astype(F32)
        uu = float(u @ u)
        q = np.clip(((X - a.astype(F32)) @ u) / max(uu, 1e-12), 0, 1) if uu > 0 else np.zeros(len(X), F32)
        P = a.astype(F32)[None, :] + q[:, None] * u[None, :]
        v = X - P
        dist = np.abs(np.sqrt(_dot(v, v)) - F32(r))
        better = dist < best
        best = np.where(better, dist, best)
        out = np.where(better[:, None], v / np.maximum(np.linalg.norm(v, axis=1, keepdims=True), 1e-6), out)
    return out.astype(F32)


def _ambient_occlusion(scene: Scene, X: np.ndarray) -> np.ndarray:
    """Less sky light on the floor right under the pipe (0.55..1)."""
    if scene.pipe_centre is None or scene.pipe_axis is None:
        return np.ones(len(X), F32)
    a = scene.pipe_centre - 0.5 * PIPE_LENGTH * scene.pipe_axis
    b = scene.pipe_centre + 0.5 * PIPE_LENGTH * scene.pipe_axis
    u = (b - a).astype(F32)
    q = np.clip(((X - a.astype(F32)) @ u) / F32(u @ u), 0, 1)
    P = a.astype(F32)[None, :] + q[:, None] * u[None, :]
    dist = np.linalg.norm((X - P)[:, :2], axis=1)
    return (1.0 - 0.45 * np.exp(-((dist / F32(1.6 * PIPE_RADIUS)) ** 2))).astype(F32)


def _lamp_backscatter(scene: Scene, cam: CameraModel, wTc: np.ndarray) -> np.ndarray:
    """Lamp light scattered back along each line of sight (single scattering,
    isotropic phase, integrated in 24 steps), at 1/8 resolution, interpolated up."""
    import cv2

    rays = _rays(cam, 8)
    d = rays.d  # camera frame
    c = scene.water.c.astype(F32)
    cbar = float(c.mean())
    far = min(6.0 / cbar, 8.0)
    steps = np.linspace(0.02, far, 24, dtype=F32)
    ds = F32(steps[1] - steps[0])
    acc = np.zeros((len(d), 3), F32)
    lamps = [np.array([s, -0.08, 0.0], F32) for s in (-0.25, 0.25)]
    for s in steps:
        X = d * s
        tr_cam = np.exp(-F32(s) * c)
        for Lp in lamps:
            v = X - Lp[None, :]
            dl2 = _dot(v, v)
            dl = np.sqrt(dl2)
            beam = np.clip(v[:, 2] / np.maximum(dl, 1e-6), 0, 1) ** 6
            e = F32(scene.light.lamp_power) * beam / np.maximum(dl2, 0.01) * np.exp(-F32(cbar) * dl)
            acc += (e[:, None] * tr_cam[None, :]) * F32(scene.water.b / (4 * np.pi)) * ds
    img = acc.reshape(rays.shape[0], rays.shape[1], 3)
    return cv2.resize(img, (cam.width, cam.height), interpolation=cv2.INTER_LINEAR)


# --------------------------------------------------------------------------- camera


def _camera_pipeline(
    lin: np.ndarray, settings: CameraSettings, wb: np.ndarray, gain: float, rng: np.random.Generator
) -> np.ndarray:
    """Linear RGB radiance -> 8-bit BGR image through optics, sensor and processing."""
    import cv2

    img: np.ndarray = lin * F32(gain)
    if settings.optical_blur_px > 0:
        img = cv2.GaussianBlur(img, (0, 0), settings.optical_blur_px)
    if settings.motion_px >= 1.0:
        n = int(math.ceil(settings.motion_px)) * 2 + 1
        k = np.zeros((n, n), np.float32)
        c = n // 2
        dx, dy = math.cos(settings.motion_angle), math.sin(settings.motion_angle)
        for s in np.linspace(-settings.motion_px / 2, settings.motion_px / 2, 4 * n):
            k[int(round(c + s * dy)), int(round(c + s * dx))] += 1.0
        img = cv2.filter2D(img, -1, k / k.sum())
    # Bayer RGGB mosaic, photo-electrons, shot + read noise
    full_well = 10000.0
    h, w = img.shape[:2]
    mosaic = np.empty((h, w), F32)
    mosaic[0::2, 0::2] = img[0::2, 0::2, 0]
    mosaic[0::2, 1::2] = img[0::2, 1::2, 1]
    mosaic[1::2, 0::2] = img[1::2, 0::2, 1]
    mosaic[1::2, 1::2] = img[1::2, 1::2, 2]
    electrons = np.clip(mosaic, 0, 1.5) * F32(full_well / max(gain / 4.0, 1.0))
    noisy = rng.poisson(electrons).astype(F32) + rng.normal(0, settings.read_noise_e, electrons.shape).astype(F32)
    mosaic = noisy / F32(full_well / max(gain / 4.0, 1.0))
    raw = np.clip(mosaic * 4095.0, 0, 4095).astype(np.uint16)
    rgb = cv2.cvtColor(raw, cv2.COLOR_BayerBG2RGB).astype(F32) / 4095.0  # OpenCV names RGGB data "BG"
    rgb *= wb[None, None, :].astype(F32)
    out = np.power(np.clip(rgb, 0, 1), 1 / 2.2)
    bgr = np.clip(out[:, :, ::-1] * 255.0 + 0.5, 0, 255).astype(np.uint8)
    if settings.jpeg_quality > 0:
        ok, buf = cv2.imencode(".jpg", bgr, [cv2.IMWRITE_JPEG_QUALITY, settings.jpeg_quality])
        if not ok:  # pragma: no cover - OpenCV always encodes an 8-bit colour image
            raise RuntimeError("JPEG encoding failed")
        bgr = cv2.imdecode(buf, cv2.IMREAD_COLOR)
    return bgr


def _white_balance(lin: np.ndarray, settings: CameraSettings, scene: Scene) -> np.ndarray:
    """RGB gains of the camera's white balance (before its error)."""
    if settings.wb_mode == "daylight":
        g = np.ones(3)
    elif settings.wb_mode == "grey_card":  # a grey card on the floor 1.5 m away, veil included
        kd = A_WATER_RGB + 0.3 * scene.water.b
        light = scene.light.daylight * np.exp(-kd * scene.depth_m)
        tr = np.exp(-scene.water.c * 1.5)
        veil = (scene.water.b / scene.water.c) * 0.2 * light
        seen = 0.5 * light * tr + veil * (1 - tr)
        g = seen[1] / seen
    else:  # the camera's auto white balance: grey world, 70 % of the way
        mean = lin[::7, ::7].reshape(-1, 3).mean(axis=0)
        g = (mean[1] / np.maximum(mean, 1e-6)) ** 0.7
    g = np.clip(g, 0.4, 5.0) * settings.wb_error
    return (g / g[1]).astype(F32)


# --------------------------------------------------------------------------- views


def _look_at(eye: np.ndarray, target: np.ndarray, roll: float = 0.0) -> np.ndarray:
    """World pose of an optical frame at ``eye`` looking at ``target`` (world z up), rolled by ``roll``."""
    z = target - eye
    z /= np.linalg.norm(z)
    x = np.cross(z, [0.0, 0.0, 1.0])
    if np.linalg.norm(x) < 1e-6:
        x = np.array([1.0, 0.0, 0.0])
    x /= np.linalg.norm(x)
    y = np.cross(z, x)
    R = np.column_stack([x, y, z])
    c, s = math.cos(roll), math.sin(roll)
    R = R @ np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]])
    T = np.eye(4)
    T[:3, :3], T[:3, 3] = R, eye
    return T


def _project(cam: CameraModel, X_cam: np.ndarray) -> np.ndarray:
    import cv2

    uv, _ = cv2.projectPoints(X_cam.reshape(-1, 1, 3).astype(np.float64), np.zeros(3), np.zeros(3), cam.K, cam.D)
    return uv.reshape(-1, 2)


def _draw_water(name: str, rng: np.random.Generator) -> Water:
    spec = WATERS[name]
    vis = float(rng.uniform(*spec["visibility_m"]))
    c_mean = VIS_LENGTHS / vis
    cdom = float(rng.uniform(*spec["cdom_blue"]))
    a = A_WATER_RGB + np.array([0.1 * cdom, 0.35 * cdom, cdom])
    b = max(c_mean - float(a.mean()), 0.02)
    return Water(a + b, b, vis)


def _draw_floor(rng: np.random.Generator) -> Floor:
    kind = str(rng.choice(["tiles", "tiles", "concrete", "painted"]))
    if kind == "tiles":
        palette = [
            [0.50, 0.66, 0.72],  # pale blue
            [0.72, 0.74, 0.74],  # white-grey
            [0.45, 0.60, 0.58],  # blue-green
            [0.30, 0.42, 0.62],  # dark blue band
        ]
        k = int(rng.integers(1, 4))
        colours = np.array([palette[i] for i in rng.choice(len(palette), size=k, replace=False)])
        colours = colours * rng.uniform(0.85, 1.1, size=(k, 1))
    elif kind == "concrete":
        g = rng.uniform(0.35, 0.6)
        colours = np.array([[g * rng.uniform(0.95, 1.05), g, g * rng.uniform(0.92, 1.08)]])
    else:
        colours = np.array([[0.42, 0.58, 0.68]]) * rng.uniform(0.8, 1.1)
    stains = []
    for _ in range(int(rng.integers(0, 6))):
        if rng.uniform() < 0.5:
            mult = np.array([0.55, 0.62, 0.5]) * rng.uniform(0.8, 1.1)  # algae: dark green-grey
        else:
            mult = np.array([1.1, 0.8, 0.6]) * rng.uniform(0.9, 1.05)  # rust: brown
        stains.append((float(rng.uniform(-3, 3)), float(rng.uniform(-3, 3)), float(rng.uniform(0.05, 0.4)), mult))
    return Floor(
        kind,
        float(rng.uniform(0.12, 0.3)),
        colours.astype(F32),
        np.array([0.3, 0.31, 0.3], F32),
        stains,
        int(rng.integers(1 << 30)),
    )


def _draw_light(water: Water, rng: np.random.Generator) -> Lighting:
    el = rng.uniform(np.radians(45), np.radians(88))
    az = rng.uniform(0, 2 * np.pi)
    sun = np.array([math.cos(el) * math.cos(az), math.cos(el) * math.sin(az), math.sin(el)])
    direct = float(rng.uniform(0.35, 0.7) * math.exp(-1.2 * water.b))
    lamp = float(rng.choice([0.0, 0.0, rng.uniform(0.2, 1.2)]))
    return Lighting(float(rng.uniform(0.6, 1.4)), sun, direct, lamp)


def _draw_camera(rng: np.random.Generator) -> CameraSettings:
    mode = str(rng.choice(["daylight", "grey_card", "auto"]))
    motion = float(rng.choice([0.0, 0.0, rng.uniform(1.0, 7.0)]))
    q = int(rng.choice([0, int(rng.integers(55, 96)), int(rng.integers(55, 96))]))
    return CameraSettings(
        mode,
        rng.uniform(0.88, 1.12, 3),
        float(rng.uniform(0.7, 1.35)),
        float(rng.uniform(0.4, 0.9)),
        motion,
        float(rng.uniform(0, np.pi)),
        q,
        float(rng.uniform(6.0, 14.0)),
    )


def make_view(
    index: int, kind: str, water_name: str, range_m: float, split: str = "eval", calib: StereoCalibration | None = None
) -> View:
    """Render view ``index`` of a split (geometry and every nuisance factor from
    their own seeded streams; see the module doc)."""
    calib = calib or eval_rig()
    if split not in SPLIT_SEEDS:
        raise ValueError(f"unknown evaluation split {split!r} (known: {', '.join(SPLIT_SEEDS)})")
    base = SPLIT_SEEDS[split]
    ss = np.random.SeedSequence([base, index, ["pipe", "arm", "partial", "nopipe"].index(kind)])
    g_geo, g_water, g_floor, g_light, g_cam, g_noise_l, g_noise_r = (np.random.default_rng(s) for s in ss.spawn(7))
    water = _draw_water(water_name, g_water)
    floor = _draw_floor(g_floor)
    light = _draw_light(water, g_light)
    cams = _draw_camera(g_cam)
    depth = float(g_geo.uniform(3.0, 4.0))
    yaw = g_geo.uniform(0, 2 * np.pi)
    axis = np.array([math.cos(yaw), math.sin(yaw), 0.0])
    centre = np.array([g_geo.uniform(-0.5, 0.5), g_geo.uniform(-0.5, 0.5), PIPE_RADIUS + g_geo.uniform(0.02, 0.08)])
    albedo = np.array([g_geo.uniform(0.62, 0.8), g_geo.uniform(0.5, 0.66), g_geo.uniform(0.03, 0.09)])
    elev = g_geo.uniform(np.radians(35), np.radians(75))
    azim = g_geo.uniform(np.radians(15), np.radians(90)) * g_geo.choice([-1, 1]) + g_geo.choice([0, np.pi])
    s_aim = g_geo.uniform(-0.3, 0.3)
    aim = centre + s_aim * axis
    horiz = np.array([math.cos(yaw + azim), math.sin(yaw + azim), 0.0])
    eye = aim + range_m * (math.cos(elev) * horiz + np.array([0, 0, math.sin(elev)]))
    roll = g_geo.uniform(-0.07, 0.07)
    target = aim.copy()
    if kind == "partial":  # swing the camera so that the pipe crosses the image border
        side = np.cross([0, 0, 1.0], aim - eye)
        side /= np.linalg.norm(side)
        off = g_geo.uniform(0.32, 0.46) * range_m * g_geo.choice([-1, 1])
        target = aim + off * side + np.array([0, 0, g_geo.uniform(-0.1, 0.1) * range_m])
    wTl = _look_at(eye, target, roll)
    if kind == "nopipe":  # look at the floor 2-4 m away from the pipe
        away = np.array([math.cos(yaw + 1.3), math.sin(yaw + 1.3), 0.0]) * g_geo.uniform(2.5, 4.0)
        wTl = _look_at(eye + away, aim + away, roll)
    arm: list[Capsule] = []
    hand = None
    if kind in ("arm", "nopipe") and (kind == "arm" or g_geo.uniform() < 0.5):
        cam_R, cam_o = wTl[:3, :3], wTl[:3, 3]
        shoulder = cam_o + cam_R @ np.array([g_geo.choice([-0.3, 0.3]), 0.32, 0.05])
        s_hand = s_aim + g_geo.uniform(-0.25, 0.25)
        hand_p = centre + s_hand * axis + np.array([0, 0, g_geo.uniform(0.12, 0.3)])
        if kind == "nopipe":
            hand_p = cam_o + cam_R @ np.array([g_geo.uniform(-0.2, 0.2), g_geo.uniform(0.0, 0.25), 0.8])
        elbow = 0.5 * (shoulder + hand_p) + np.array([0, 0, g_geo.uniform(0.05, 0.25)])
        wrist = hand_p + 0.15 * (elbow - hand_p) / np.linalg.norm(elbow - hand_p)
        lr = float(g_geo.uniform(0.045, 0.06))
        arm = [Capsule(shoulder, elbow, lr), Capsule(elbow, wrist, lr * 0.85)]
        hand = (hand_p, float(g_geo.uniform(0.07, 0.09)))
    scene = Scene(
        depth,
        floor,
        water,
        light,
        None if kind == "nopipe" else centre,
        None if kind == "nopipe" else axis,
        albedo,
        int(g_geo.integers(1 << 30)),
        arm,
        hand,
    )
    lTr = np.eye(4)
    lTr[:3, :3], lTr[:3, 3] = calib.R.T, -calib.R.T @ calib.T
    images, arm_px, pipe_px = [], [], []
    lin_l, arm_l, pipe_l = _render_linear(scene, calib.left, wTl)
    lin_r, arm_r, pipe_r = _render_linear(scene, calib.right, wTl @ lTr)
    wb = _white_balance(lin_l, cams, scene)
    mean = float((lin_l[::5, ::5] * wb[None, None, :]).mean())
    gain = float(np.clip(0.16 * cams.exposure_bias / max(mean, 1e-6), 0.5, 64.0))
    for lin, g in ((lin_l, g_noise_l), (lin_r, g_noise_r)):
        images.append(_camera_pipeline(lin, cams, wb, gain, g))
    arm_px, pipe_px = [arm_l, arm_r], [pipe_l, pipe_r]
    masks = None
    if arm:
        import cv2

        kern = cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (9, 9))
        masks_l = []
        for m in arm_px:
            shift = g_geo.uniform(-2, 2, 2)
            mm = cv2.dilate(m.astype(np.uint8) * 255, kern)
            M = np.array([[1, 0, shift[0]], [0, 1, shift[1]]], np.float32)
            masks_l.append(cv2.warpAffine(mm, M, (mm.shape[1], mm.shape[0])))
        masks = (masks_l[0], masks_l[1])
    lTw = np.linalg.inv(wTl)
    cam_T_pipe = None
    ends_cam = None
    visible: tuple[int, ...] = ()
    if kind != "nopipe":
        P = np.eye(4)
        z = np.cross(axis, [0, 0, 1.0])
        P[:3, :3] = np.column_stack([axis, np.cross(z, axis), z])  # x along the axis (orientation irrelevant)
        P[:3, 3] = centre
        cam_T_pipe = lTw @ P
        ends_w = np.array([centre - 0.5 * PIPE_LENGTH * axis, centre + 0.5 * PIPE_LENGTH * axis])
        ends_cam = ends_w @ lTw[:3, :3].T + lTw[:3, 3]
        visible = tuple(k for k in (0, 1) if _end_visible(calib.left, ends_cam[k], lTw[:3, :3] @ axis, arm_l))
    gravity = lTw[:3, :3] @ np.array([0, 0, -1.0])
    params = {
        "visibility_m": water.visibility_m,
        "c": water.c.tolist(),
        "floor": floor.kind,
        "lamp_power": light.lamp_power,
        "direct_share": light.direct_share,
        "wb_mode": cams.wb_mode,
        "motion_px": cams.motion_px,
        "jpeg_quality": cams.jpeg_quality,
        "gain": gain,
        "elevation_deg": float(np.degrees(elev)),
        "azimuth_deg": float(np.degrees(azim)),
        "pipe_px": [int(p.sum()) for p in pipe_px],
        "arm_hides_px": [int((a & ~p).sum()) for a, p in zip(arm_px, pipe_px)],
    }
    return View(
        f"{split}-{water_name}-{kind}-{index:04d}",
        kind,
        water_name,
        float(range_m),
        images[0],
        images[1],
        cam_T_pipe,
        ends_cam,
        visible,
        gravity,
        masks,
        params,
        pipe_l if kind != "nopipe" else None,
    )


def _end_visible(cam: CameraModel, end_cam: np.ndarray, axis_cam: np.ndarray, arm_px: np.ndarray) -> bool:
    """The end cap's rim projects inside the image (margin 6 px) and off the arm."""
    u = np.cross(axis_cam, [1.0, 0, 0])
    if np.linalg.norm(u) < 0.1:
        u = np.cross(axis_cam, [0, 1.0, 0])
    u /= np.linalg.norm(u)
    v = np.cross(axis_cam, u)
    th = np.linspace(0, 2 * np.pi, 24, endpoint=False)
    rim = end_cam[None, :] + PIPE_RADIUS * (np.cos(th)[:, None] * u + np.sin(th)[:, None] * v)
    if np.any(rim[:, 2] <= 0.05):
        return False
    uv = _project(cam, rim)
    if np.any(uv < 6) or np.any(uv[:, 0] > cam.width - 7) or np.any(uv[:, 1] > cam.height - 7):
        return False
    ij = np.rint(uv).astype(int)
    return not bool(arm_px[ij[:, 1], ij[:, 0]].any())


#: The evaluation plan: (water, kind, count, range interval m) per row.
PLAN: tuple[tuple[str, str, int, tuple[float, float]], ...] = (
    ("clear", "pipe", 36, (0.9, 2.5)),
    ("clear", "arm", 12, (0.9, 2.0)),
    ("clear", "partial", 12, (0.9, 2.5)),
    ("clear", "nopipe", 12, (0.9, 2.5)),
    ("slightly_turbid", "pipe", 36, (0.9, 2.5)),
    ("slightly_turbid", "arm", 12, (0.9, 2.0)),
    ("slightly_turbid", "partial", 12, (0.9, 2.5)),
    ("slightly_turbid", "nopipe", 12, (0.9, 2.5)),
    ("very_turbid", "pipe", 30, (0.9, 1.3)),
    ("very_turbid", "arm", 8, (0.9, 1.3)),
    ("very_turbid", "pipe", 12, (1.3, 2.5)),
    ("very_turbid", "nopipe", 12, (0.9, 2.5)),
)


def plan(split: str = "eval", scale: float = 1.0) -> list[tuple[int, str, str, float]]:
    """``(index, kind, water, range_m)`` of every view of a split; ``scale`` < 1
    takes a proportional subset (at least one per row)."""
    out = []
    index = 0
    for water, kind, count, (lo, hi) in PLAN:
        n = max(1, int(round(count * scale)))
        for k in range(n):
            rng_m = lo + (hi - lo) * (k + 0.5) / n  # ranges spread evenly over the interval
            out.append((index, kind, water, float(rng_m)))
            index += 1
    return out


# --------------------------------------------------------------------------- how visible the pipe is


@dataclass(frozen=True)
class PipeContrast:
    """How far the pipe's colour stands from the floor beside it in a view's left image as the
    detector gets it (8-bit BGR levels of the delivered image, before any restoration): the
    mean colour over the pipe's visible pixels at least :data:`CONTRAST_INSET_PX` inside its
    outline, less the mean over a ring :data:`CONTRAST_INSET_PX` to :data:`CONTRAST_RING_PX`
    outside it (arm pixels left out of both; the ring's mean averages both sides of the pipe,
    so a brightness gradient across it cancels), as a whole (``colour``: the difference's
    length) and without its grey part (``chroma``: the difference less its mean over the
    channels, the part that a change of brightness alone does not make); and the pixel noise
    in the ring (``noise``: the standard deviation of the image less its 5 x 5 mean, averaged
    over the channels)."""

    colour: float
    chroma: float
    noise: float


#: The pipe's core starts, and the ring around it begins, this far (px) from its outline: the
#: optics' and motion blur's width, so that neither mixes the other's colour in.
CONTRAST_INSET_PX = 5
#: The ring around the pipe ends this far (px) from its outline (a fraction of its width at 1-2 m).
CONTRAST_RING_PX = 25


def pipe_contrast(view: View) -> PipeContrast | None:
    """The :class:`PipeContrast` of ``view`` (its left image as it stands: compressed again
    first, where the benchmark does so); None without a pipe or with fewer than 50 pixels in its
    core or its ring."""
    import cv2

    if view.pipe_left is None:
        return None
    img = view.left.astype(np.float32)
    pipe = view.pipe_left.astype(np.uint8)
    inset, ring_px = 2 * CONTRAST_INSET_PX + 1, 2 * CONTRAST_RING_PX + 1
    core = cv2.erode(pipe, np.ones((inset, inset), np.uint8)) > 0
    ring = (cv2.dilate(pipe, np.ones((ring_px, ring_px), np.uint8)) > 0) & ~(
        cv2.dilate(pipe, np.ones((inset, inset), np.uint8)) > 0
    )
    if view.arm_masks is not None:
        arm = cv2.dilate((view.arm_masks[0] > 0).astype(np.uint8), np.ones((inset, inset), np.uint8)) > 0
        core &= ~arm
        ring &= ~arm
    if core.sum() < 50 or ring.sum() < 50:
        return None
    diff = img[core].mean(axis=0) - img[ring].mean(axis=0)
    fine = img - cv2.blur(img, (5, 5))
    return PipeContrast(
        colour=float(np.linalg.norm(diff)),
        chroma=float(np.linalg.norm(diff - diff.mean())),
        noise=float(fine[ring].std(axis=0).mean()),
    )


# --------------------------------------------------------------------------- cache


def save_view(view: View, folder: Path) -> Path:
    """Write a view as ``<name>.npz`` (images PNG-encoded, lossless: the JPEG stage is already in them)."""
    import json

    import cv2

    folder.mkdir(parents=True, exist_ok=True)
    enc = {
        k: np.frombuffer(cv2.imencode(".png", im)[1].tobytes(), np.uint8)
        for k, im in (("left", view.left), ("right", view.right))
    }
    extra: dict[str, np.ndarray] = {}
    if view.cam_T_pipe is not None and view.ends_cam is not None:
        extra = {"cam_T_pipe": view.cam_T_pipe, "ends_cam": view.ends_cam}
    if view.pipe_left is not None:
        extra["pipe_left"] = np.packbits(view.pipe_left > 0)
    if view.arm_masks is not None:
        extra["arm_left"] = np.packbits(view.arm_masks[0] > 0)
        extra["arm_right"] = np.packbits(view.arm_masks[1] > 0)
    meta = {
        "name": view.name,
        "kind": view.kind,
        "water": view.water_name,
        "range_m": view.range_m,
        "ends_visible": list(view.ends_visible),
        "params": view.params,
    }
    path = folder / f"{view.name}.npz"
    arrays: dict[str, np.ndarray] = {
        "meta": np.frombuffer(json.dumps(meta).encode(), np.uint8),
        "gravity": view.gravity_cam,
        **enc,
        **extra,
    }
    np.savez(path, **arrays)  # type: ignore[arg-type]
    return path


def load_view(path: Path) -> View:
    """A view written by :func:`save_view`."""
    import json

    import cv2

    z = np.load(path)
    meta = json.loads(z["meta"].tobytes().decode())
    left = cv2.imdecode(z["left"], cv2.IMREAD_COLOR)
    right = cv2.imdecode(z["right"], cv2.IMREAD_COLOR)
    if left is None or right is None:
        raise ValueError(f"{path}: an image does not decode")
    masks = None
    if "arm_left" in z:
        n = left.shape[0] * left.shape[1]
        masks = tuple(
            (np.unpackbits(z[k])[:n].reshape(left.shape[:2]) * 255).astype(np.uint8) for k in ("arm_left", "arm_right")
        )
    return View(
        meta["name"],
        meta["kind"],
        meta["water"],
        meta["range_m"],
        left,
        right,
        z["cam_T_pipe"] if "cam_T_pipe" in z else None,
        z["ends_cam"] if "ends_cam" in z else None,
        tuple(meta["ends_visible"]),
        z["gravity"],
        masks,  # type: ignore[arg-type]
        meta["params"],
        np.unpackbits(z["pipe_left"])[: left.shape[0] * left.shape[1]].reshape(left.shape[:2]).astype(bool)
        if "pipe_left" in z
        else None,
    )


def views(split: str = "eval", scale: float = 1.0, cache: Path | None = None, progress: bool = False) -> list[Path]:
    """Paths of every view of a split, rendering (and caching in ``cache``) those not there yet."""
    import sys
    import tempfile

    folder = cache or Path(tempfile.gettempdir()) / f"maris-evalset-{split}"
    calib = eval_rig()
    out = []
    todo = plan(split, scale)
    for k, (index, kind, water, rng_m) in enumerate(todo):
        name = f"{split}-{water}-{kind}-{index:04d}"
        path = folder / f"{name}.npz"
        if not path.is_file():
            save_view(make_view(index, kind, water, rng_m, split, calib), folder)
            if progress:
                print(f"  rendered {k + 1}/{len(todo)} {name}", file=sys.stderr)
        out.append(path)
    return out
