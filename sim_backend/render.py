"""Stereo images of the simulated pool, by ray casting in numpy.

:class:`StereoRenderer` renders what the two calibrated cameras see (each
camera's distortion included: every pixel's ray comes from undoing the
calibration's distortion) of a :class:`Scene`: the pool (tiled floor and
walls, the water surface), the pipe (a capped cylinder) and the arm (cylinders
along the links, balls at the joints and for the hand), lit and seen through
the water of :mod:`sim_backend.render_optics`. Output: 8-bit BGR images, like
the cameras'.

Cost: the pool is shaded at a quarter of the resolution and interpolated up
(it is smooth but for the grout lines and caustics, which come out soft, as
behind a slightly defocused lens); objects are
intersected at full resolution over their projected bounding boxes only, so
their edges are sharp. Arrays are kept per coordinate (x, y, z vectors) so
everything is cheap element-wise arithmetic. Geometry runs in each camera's
frame (rays from its origin); the pool is in world NED. Deterministic for a
given ``rng``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from vision.calibration import CameraModel, StereoCalibration, undistort_points

from .render_optics import (
    ARM_ALBEDO_BGR,
    GROUT_ALBEDO_BGR,
    PIPE_ALBEDO_BGR,
    SURFACE_RADIANCE,
    TILE_ALBEDO_BGR,
    CameraResponse,
    WaterOptics,
    caustic_texture,
    srgb_lut,
)

#: Pool tile size (m) and grout width (m).
TILE_M = 0.25
GROUT_M = 0.012
#: Lamp positions in the camera frame (m): beside the camera, pointing along its axis.
LAMPS_CAM = ((-0.3, 0.05, 0.0), (0.3, 0.05, 0.0))
F32 = np.float32
#: Objects closer than this (m, plus their radius) to the camera plane are not drawn (inside the housing).
NEAR_M = 0.05


@dataclass
class Scene:
    """What is in the water at one instant (world NED, m).

    pool_size: (x, y, depth). pipe_centre: (4, 4) pose, x along the axis.
    arm_points: (k, 3) joint origins and tool point; arm_radius, hand_radius (m).
    t: time (s), moves the caustics."""

    pool_size: tuple[float, float, float]
    pipe_centre: np.ndarray
    pipe_length: float
    pipe_radius: float
    arm_points: np.ndarray | None = None
    arm_radius: float = 0.07
    hand_radius: float = 0.10
    t: float = 0.0


class _Rays:
    """Per-pixel unit rays of one camera (its frame), as three (N,) vectors."""

    def __init__(self, cam: CameraModel):
        self.cam = cam
        h, w = cam.height, cam.width
        v, u = np.mgrid[0:h, 0:w]
        xy = undistort_points(np.stack([u.ravel(), v.ravel()], axis=1), cam)
        norm = np.sqrt(xy[:, 0] ** 2 + xy[:, 1] ** 2 + 1.0)
        self.x, self.y, self.z = (xy[:, 0] / norm).astype(F32), (xy[:, 1] / norm).astype(F32), (1.0 / norm).astype(F32)
        self.vignette = (1.0 / norm**4).astype(F32)  # cos^4 law
        self.x_range = (float(xy[:, 0].min()), float(xy[:, 0].max()))
        self.y_range = (float(xy[:, 1].min()), float(xy[:, 1].max()))

    def pixel_box(self, pts_cam: np.ndarray, margin: int = 3) -> tuple[int, int, int, int] | None:
        """Rows/cols (r0, r1, c0, c1) that may see an object whose hull points are
        ``pts_cam`` (k, 3); the whole image if some are behind the camera; None if
        it is out of view."""
        h, w = self.cam.height, self.cam.width
        z = pts_cam[:, 2]
        if np.all(z <= 0.02):
            return None
        if np.any(z <= 0.02):
            return 0, h, 0, w
        xy = pts_cam[:, :2] / z[:, None]
        x0, x1 = max(xy[:, 0].min(), self.x_range[0]), min(xy[:, 0].max(), self.x_range[1])
        y0, y1 = max(xy[:, 1].min(), self.y_range[0]), min(xy[:, 1].max(), self.y_range[1])
        if x0 > x1 or y0 > y1:
            return None
        # the clipped box's corners and edge midpoints through the distortion model
        xs = np.array([x0, 0.5 * (x0 + x1), x1, x0, x1, x0, 0.5 * (x0 + x1), x1])
        ys = np.array([y0, y0, y0, 0.5 * (y0 + y1), 0.5 * (y0 + y1), y1, y1, y1])
        uv = _distort(self.cam, xs, ys)
        c0, c1 = int(np.floor(uv[:, 0].min())) - margin, int(np.ceil(uv[:, 0].max())) + margin + 1
        r0, r1 = int(np.floor(uv[:, 1].min())) - margin, int(np.ceil(uv[:, 1].max())) + margin + 1
        c0, r0, c1, r1 = max(c0, 0), max(r0, 0), min(c1, w), min(r1, h)
        return (r0, r1, c0, c1) if (r1 > r0 and c1 > c0) else None


def _distort(cam: CameraModel, x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """Pixels (k, 2) of normalized points through OpenCV's k1 k2 p1 p2 k3 model
    (the same as ``cv2.projectPoints`` for these terms; higher ones are ignored),
    or its fisheye (equidistant) model."""
    K = cam.K
    if cam.model == "equidistant":
        k = np.zeros(4)
        k[: min(4, len(cam.D))] = cam.D[:4]
        r = np.sqrt(x * x + y * y)
        th = np.arctan(r)
        th2 = th * th
        thd = th * (1.0 + th2 * (k[0] + th2 * (k[1] + th2 * (k[2] + th2 * k[3]))))
        scale = np.where(r > 1e-12, thd / np.maximum(r, 1e-12), 1.0)
        xd, yd = x * scale, y * scale
        return np.column_stack([K[0, 0] * xd + K[0, 1] * yd + K[0, 2], K[1, 1] * yd + K[1, 2]])
    D = np.zeros(5)
    D[: min(5, len(cam.D))] = cam.D[:5]
    k1, k2, p1, p2, k3 = D
    r2 = x * x + y * y
    radial = 1.0 + r2 * (k1 + r2 * (k2 + r2 * k3))
    xd = x * radial + 2.0 * p1 * x * y + p2 * (r2 + 2.0 * x * x)
    yd = y * radial + p1 * (r2 + 2.0 * y * y) + 2.0 * p2 * x * y
    return np.column_stack([K[0, 0] * xd + K[0, 1] * yd + K[0, 2], K[1, 1] * yd + K[1, 2]])


_CORNERS = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)], dtype=float)


def _box(points: np.ndarray, r: float) -> np.ndarray:
    """Corners (8k, 3) of the cubes of half size ``r`` around ``points`` (k, 3)."""
    return (points[:, None, :] + r * _CORNERS[None]).reshape(-1, 3)


def _cylinder_hit(
    d: tuple, c: np.ndarray, a: np.ndarray, r: float, half: float, caps: bool
) -> tuple[np.ndarray, tuple]:
    """Nearest hit distance (inf: none) of unit rays ``d = (x, y, z)`` from the
    origin with a cylinder (centre ``c``, unit axis ``a``, radius, half length),
    and the normal there (3 vectors)."""
    dx, dy, dz = d
    da = dx * F32(a[0]) + dy * F32(a[1]) + dz * F32(a[2])
    ca = float(c @ a)
    m = -c + ca * a  # origin minus centre, axis part removed
    A = 1.0 - da * da
    B = (dx * F32(m[0]) + dy * F32(m[1]) + dz * F32(m[2])) - da * F32(m @ a)
    C = float(m @ m) - r * r
    disc = B * B - A * C
    with np.errstate(invalid="ignore", divide="ignore"):
        sq = np.sqrt(np.maximum(disc, 0.0))
        t = (-B - sq) / A
        t = np.where(disc >= 0.0, np.where(t > 1e-4, t, (-B + sq) / A), np.inf)
        t = np.where((t > 1e-4) & (np.abs(t * da - ca) <= half), t, np.inf).astype(F32)
        caps_hit = None
        if caps:
            for sgn in (-1.0, 1.0):
                pc = c + sgn * half * a
                tc = (float(pc @ a) / da).astype(F32)
                ex, ey, ez = dx * tc - F32(pc[0]), dy * tc - F32(pc[1]), dz * tc - F32(pc[2])
                ok = (tc > 1e-4) & (ex * ex + ey * ey + ez * ez <= r * r) & (tc < t)
                if ok.any():
                    t = np.where(ok, tc, t)
                    caps_hit = np.where(ok, F32(sgn), caps_hit if caps_hit is not None else F32(0.0))
    tt = np.where(np.isfinite(t), t, 0.0)
    px, py, pz = dx * tt - F32(c[0]), dy * tt - F32(c[1]), dz * tt - F32(c[2])
    ax = px * F32(a[0]) + py * F32(a[1]) + pz * F32(a[2])
    nx, ny, nz = (px - ax * F32(a[0])) / F32(r), (py - ax * F32(a[1])) / F32(r), (pz - ax * F32(a[2])) / F32(r)
    if caps_hit is not None:
        on = caps_hit != 0.0
        nx, ny, nz = (np.where(on, caps_hit * F32(a[i]), n) for i, n in enumerate((nx, ny, nz)))
    return t, (nx, ny, nz)


def _sphere_hit(d: tuple, c: np.ndarray, r: float) -> tuple[np.ndarray, tuple]:
    dx, dy, dz = d
    b = dx * F32(c[0]) + dy * F32(c[1]) + dz * F32(c[2])
    disc = b * b - F32(float(c @ c) - r * r)
    with np.errstate(invalid="ignore"):
        t = np.where(disc >= 0.0, b - np.sqrt(np.maximum(disc, 0.0)), np.inf).astype(F32)
    t = np.where(t > 1e-4, t, np.inf).astype(F32)
    tt = np.where(np.isfinite(t), t, 0.0)
    return t, ((dx * tt - F32(c[0])) / F32(r), (dy * tt - F32(c[1])) / F32(r), (dz * tt - F32(c[2])) / F32(r))


class StereoRenderer:
    """Renders the two cameras of ``calib`` (left = rig frame) in ``optics`` water."""

    def __init__(
        self,
        calib: StereoCalibration,
        optics: WaterOptics,
        rng: np.random.Generator,
        response: CameraResponse | None = None,
        background_scale: float = 0.25,
    ):
        self.calib = calib
        self.optics = optics
        self.response = response or CameraResponse.for_water(optics)
        self._full = (_Rays(calib.left), _Rays(calib.right))
        #: the pool is shaded at this fraction of the resolution and interpolated up
        self.background_scale = float(background_scale)
        self._half = (_Rays(calib.left.scaled(background_scale)), _Rays(calib.right.scaled(background_scale)))
        lTr = np.eye(4)
        lTr[:3, :3], lTr[:3, 3] = calib.R.T, -calib.R.T @ calib.T
        self._left_T_right = lTr
        self._rng = rng
        self._lut = srgb_lut()
        self._caustics = caustic_texture()
        n = calib.left.width * calib.left.height * 3
        self._noise = rng.standard_normal(n + 4099).astype(F32)
        self._zbufs: dict[int, tuple] = {}
        self._c = optics.c.astype(F32)
        self._kd = optics.k_diffuse.astype(F32)

    def pipe_in_view(self, scene: Scene, world_T_left: np.ndarray, margin_px: int = 20) -> bool:
        """True if the pipe's bounding box projects into either image (with a margin)."""
        c_w, a_w = scene.pipe_centre[:3, 3], scene.pipe_centre[:3, 0]
        hl = 0.5 * scene.pipe_length
        hull_w = _box(np.array([c_w - hl * a_w, c_w + hl * a_w]), scene.pipe_radius)
        for k, wTc in enumerate((world_T_left, world_T_left @ self._left_T_right)):
            Rcw = wTc[:3, :3].T
            if self._full[k].pixel_box(hull_w @ Rcw.T - Rcw @ wTc[:3, 3], margin_px) is not None:
                return True
        return False

    def render(self, scene: Scene, world_T_left: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """BGR uint8 images (left, right) of ``scene`` seen from the rig at ``world_T_left`` (4, 4)."""
        wTr = world_T_left @ self._left_T_right
        return self._render_one(scene, world_T_left, 0), self._render_one(scene, wTr, 1)

    # ------------------------------------------------------------------ one camera

    def _render_one(self, scene: Scene, wTc: np.ndarray, k: int) -> np.ndarray:
        # OpenCV loads when the first rendered image is drawn (scenario vision.model: rendered):
        # every simulator imports this module, and the table vision model never needs it
        import cv2

        full, half = self._full[k], self._half[k]
        cam = full.cam
        h, w = cam.height, cam.width
        Rwc, o = wTc[:3, :3], wTc[:3, 3]
        self._veil_cache = self._veil(o)
        _, bg = self._pool(scene, Rwc, o, (half.x, half.y, half.z))
        bg *= half.vignette[:, None]
        wb = self._white_balance(bg)
        gain = self._exposure(bg, wb)
        g = (wb * gain).astype(F32)
        bg8 = self._encode(bg * g)
        img = cv2.resize(bg8.reshape(half.cam.height, half.cam.width, 3), (w, h), interpolation=cv2.INTER_LINEAR)
        flat = img.reshape(-1, 3)
        hit = self._objects(scene, Rwc, o, full)
        if hit is not None:
            idx, rad = hit
            flat[idx] = self._encode(rad * (full.vignette[idx, None] * g))
        if self.response.blur_px > 0:
            img = cv2.GaussianBlur(img, (0, 0), self.response.blur_px)
        return self._add_noise(img, gain)

    def _white_balance(self, img: np.ndarray) -> np.ndarray:
        """Per-channel gains (BGR): the camera's auto white balance (grey world
        over the frame, gains limited to 0.5-4), or the fixed gains of the response."""
        if self.response.white_balance is not None:
            return self.response.white_balance
        mean = img[::13].mean(axis=0)
        g = float(mean[1]) / np.maximum(mean, 1e-6)
        return np.clip(g, 0.5, 4.0).astype(F32)

    def _exposure(self, img: np.ndarray, wb: np.ndarray) -> float:
        """Auto exposure: the gain bringing the frame's mean linear level to the target."""
        resp = self.response
        mean = float((img[::5] * wb).mean())
        return float(np.clip(resp.target_mean / max(mean, 1e-6), resp.min_gain, resp.max_gain))

    def _encode(self, lin: np.ndarray) -> np.ndarray:
        """Linear levels (0..1) -> 8-bit sRGB values (same shape), through a 12-bit table."""
        return self._lut[np.clip(lin * F32(4095.0), 0, 4095).astype(np.uint16)]

    def _add_noise(self, img: np.ndarray, gain: float) -> np.ndarray:
        """Sensor noise (read + shot noise at the frame's mean level, one sigma per
        frame), in 8-bit units through the slope of the sRGB curve at the mean level."""
        resp = self.response
        m = resp.target_mean
        sigma_lin = np.sqrt(resp.read_noise**2 * gain * gain + m * gain / resp.full_well_e)
        slope = 255.0 * 1.055 / 2.4 * m ** (1.0 / 2.4 - 1.0)
        off = int(self._rng.integers(0, 4096))
        out = img.reshape(-1).astype(F32)
        out += F32(sigma_lin * slope) * self._noise[off : off + out.size]
        out += F32(0.5)
        np.clip(out, 0.0, 255.0, out=out)
        return out.astype(np.uint8).reshape(img.shape)

    def _box_t(self, Rwc: np.ndarray, o: np.ndarray, d: tuple, size: tuple) -> tuple:
        """Distance to the pool's walls/floor/surface along rays ``d`` (camera frame),
        which face was hit (0: x wall, 1: y wall, 2: floor or surface), world directions."""
        dx, dy, dz = d
        wx = F32(Rwc[0, 0]) * dx + F32(Rwc[0, 1]) * dy + F32(Rwc[0, 2]) * dz
        wy = F32(Rwc[1, 0]) * dx + F32(Rwc[1, 1]) * dy + F32(Rwc[1, 2]) * dz
        wz = F32(Rwc[2, 0]) * dx + F32(Rwc[2, 1]) * dy + F32(Rwc[2, 2]) * dz
        ts = []
        with np.errstate(divide="ignore", invalid="ignore"):
            for comp, lim, oo in ((wx, size[0], o[0]), (wy, size[1], o[1]), (wz, size[2], o[2])):
                tt = np.where(comp > 0, F32(lim - oo), F32(-oo)) / comp
                ts.append(np.where(tt > 0, tt, np.inf))
        t = np.minimum(np.minimum(ts[0], ts[1]), ts[2])
        face = np.where(ts[2] <= t, 2, np.where(ts[0] <= t, 0, 1)).astype(np.int8)
        return np.minimum(t, F32(200.0)).astype(F32), face, (wx, wy, wz)

    def _pool(self, scene: Scene, Rwc: np.ndarray, o: np.ndarray, d: tuple) -> tuple[np.ndarray, np.ndarray]:
        """Distance and linear radiance (N, 3) of the pool along rays ``d``."""
        t, face, (wx, wy, wz) = self._box_t(Rwc, o, d, scene.pool_size)
        Px, Py, Pz = F32(o[0]) + wx * t, F32(o[1]) + wy * t, F32(o[2]) + wz * t
        f0, f1, f2 = face == 0, face == 1, face == 2
        u = np.where(f0, Py, Px)
        v = np.where(f2, Py, Pz)
        g = F32(GROUT_M)
        grout = ((u + g / 2) - np.floor((u + g / 2) / TILE_M) * F32(TILE_M) < g) | (
            (v + g / 2) - np.floor((v + g / 2) / TILE_M) * F32(TILE_M) < g
        )
        albedo = np.where(grout[:, None], GROUT_ALBEDO_BGR.astype(F32), TILE_ALBEDO_BGR.astype(F32))
        # world normals face the camera side; in the camera frame n_c = R^T n_w
        sx, sy, sz = -np.sign(wx) * f0, -np.sign(wy) * f1, -np.sign(wz) * f2
        n = tuple(F32(Rwc[0, j]) * sx + F32(Rwc[1, j]) * sy + F32(Rwc[2, j]) * sz for j in range(3))
        up = np.maximum(-sz, 0.0).astype(F32)  # world up is -z
        surface = f2 & (wz < 0)
        rad = self._shade(scene, t, d, n, albedo, Pz, up, Px, Py)
        if surface.any():
            tr = np.exp(-np.multiply.outer(t[surface], self._c))
            rad[surface] = SURFACE_RADIANCE * self.optics.daylight * tr + self._veil(o) * (1.0 - tr)
        return t, rad

    def _veil(self, o: np.ndarray) -> np.ndarray:
        return self.optics.veil(float(o[2])).astype(F32)

    def _shade(self, scene: Scene, t, d: tuple, n: tuple, albedo, depth, up, wx, wy) -> np.ndarray:
        """Linear radiance (k, 3) reaching the camera from surface points at
        distance ``t`` along rays ``d`` with normals ``n`` (camera frame)."""
        opt = self.optics
        c = self._c
        amb = F32(opt.daylight) * np.exp(-np.multiply.outer(np.maximum(depth, 0.0), self._kd))
        amb *= (0.35 + 0.65 * up)[:, None]
        if opt.caustics > 0:
            tex = self._caustics
            kk = tex.shape[0]
            shift = F32(scene.t * 0.11)
            ci = ((wx + shift) * kk).astype(np.int64) % kk
            cj = ((wy - 0.7 * shift) * kk).astype(np.int64) % kk
            amb *= (1.0 + F32(opt.caustics) * up * (tex[ci, cj] - 1.0))[:, None]
        dx, dy, dz = d
        X = (dx * t, dy * t, dz * t)
        lamp = np.zeros(len(t), F32)
        c_mean = F32(float(opt.c.mean()))
        for L in LAMPS_CAM if opt.lamp_power > 0 else ():
            vx, vy, vz = F32(L[0]) - X[0], F32(L[1]) - X[1], F32(L[2]) - X[2]
            dist2 = vx * vx + vy * vy + vz * vz
            dist = np.sqrt(dist2)
            inv = 1.0 / np.maximum(dist, 1e-6)
            cos_in = np.clip((vx * n[0] + vy * n[1] + vz * n[2]) * inv, 0.0, 1.0)
            beam = np.clip(-vz * inv, 0.0, 1.0) ** 4
            lamp += F32(opt.lamp_power) * cos_in * beam / np.maximum(dist2, 0.05) * np.exp(-c_mean * dist)
        J = albedo * (amb + lamp[:, None]) if opt.lamp_power > 0 else albedo * amb
        tr = np.exp(-np.multiply.outer(t, c))
        return (J * tr + self._veil_cache * (1.0 - tr)).astype(F32)

    def _objects(
        self, scene: Scene, Rwc: np.ndarray, o: np.ndarray, rays: _Rays
    ) -> tuple[np.ndarray, np.ndarray] | None:
        """Intersect the pipe and the arm over their pixel boxes: pixel indices and
        linear radiance (k, 3) of the object pixels, or None."""
        Rcw = Rwc.T
        ocw = -Rcw @ o
        tf = lambda p: np.asarray(p, float) @ Rcw.T + ocw  # noqa: E731 - world -> camera
        objs: list[tuple] = []
        c_w, a_w = scene.pipe_centre[:3, 3], scene.pipe_centre[:3, 0]
        hl = 0.5 * scene.pipe_length
        self._add_cylinder(objs, tf(c_w - hl * a_w), tf(c_w + hl * a_w), scene.pipe_radius, True, PIPE_ALBEDO_BGR)
        if scene.arm_points is not None and len(scene.arm_points) >= 2:
            pts = tf(np.asarray(scene.arm_points, float))
            ar = scene.arm_radius
            for a, b in zip(pts[:-1], pts[1:]):
                self._add_cylinder(objs, a, b, ar, False, ARM_ALBEDO_BGR)
            for p in pts[:-1]:
                if p[2] > ar + NEAR_M:
                    objs.append(("sph", _box(p[None], ar), p, ar, ARM_ALBEDO_BGR))
            hr = scene.hand_radius
            if pts[-1][2] > hr + NEAR_M:
                objs.append(("sph", _box(pts[-1][None], hr), pts[-1], hr, ARM_ALBEDO_BGR))
        w = rays.cam.width
        zb, nb, cb = self._buffers(rays)
        boxes = []
        for ob in objs:  # z-buffer over each object's pixel box
            box = rays.pixel_box(ob[1])
            if box is None:
                continue
            r0, r1, c0, c1 = box
            boxes.append(box)
            idx = (np.arange(r0, r1)[:, None] * w + np.arange(c0, c1)[None, :]).ravel()
            d = (rays.x[idx], rays.y[idx], rays.z[idx])
            if ob[0] == "cyl":
                th, nh = _cylinder_hit(d, ob[2], ob[3], ob[4], ob[5], ob[6])
                col = ob[7]
            else:
                th, nh = _sphere_hit(d, ob[2], ob[3])
                col = ob[4]
            closer = th < zb[idx]
            if closer.any():
                sel = idx[closer]
                zb[sel] = th[closer]
                for j in range(3):
                    nb[j][sel] = nh[j][closer]
                cb[sel] = col
        if not boxes:
            return None
        r0, r1 = min(b[0] for b in boxes), max(b[1] for b in boxes)
        c0, c1 = min(b[2] for b in boxes), max(b[3] for b in boxes)
        union = (np.arange(r0, r1)[:, None] * w + np.arange(c0, c1)[None, :]).ravel()
        idx = union[np.isfinite(zb[union])]
        t, nrm, col = zb[idx].copy(), np.column_stack([nb[j][idx] for j in range(3)]), cb[idx].copy()
        zb[idx] = np.inf  # reset the buffer for the next frame
        if len(idx) == 0:
            return None
        d = (rays.x[idx], rays.y[idx], rays.z[idx])
        pool_t, _, _ = self._box_t(Rwc, o, d, scene.pool_size)
        front = t < pool_t
        if not front.any():
            return None
        idx, t, nrm, col = idx[front], t[front], nrm[front], col[front]
        d = (d[0][front], d[1][front], d[2][front])
        X = (d[0] * t, d[1] * t, d[2] * t)
        wz = F32(o[2]) + F32(Rwc[2, 0]) * X[0] + F32(Rwc[2, 1]) * X[1] + F32(Rwc[2, 2]) * X[2]
        wx = F32(o[0]) + F32(Rwc[0, 0]) * X[0] + F32(Rwc[0, 1]) * X[1] + F32(Rwc[0, 2]) * X[2]
        wy = F32(o[1]) + F32(Rwc[1, 0]) * X[0] + F32(Rwc[1, 1]) * X[1] + F32(Rwc[1, 2]) * X[2]
        n = (nrm[:, 0], nrm[:, 1], nrm[:, 2])
        up = np.clip(-(F32(Rwc[2, 0]) * n[0] + F32(Rwc[2, 1]) * n[1] + F32(Rwc[2, 2]) * n[2]), 0.0, 1.0)
        return idx, self._shade(scene, t, d, n, col, wz, up, wx, wy)

    def _buffers(self, rays: _Rays) -> tuple[np.ndarray, list[np.ndarray], np.ndarray]:
        """Per-camera z-buffer (inf where empty), normal and albedo buffers, kept between frames."""
        key = id(rays)
        buf = self._zbufs.get(key)
        if buf is None:
            n = rays.cam.width * rays.cam.height
            buf = self._zbufs[key] = (
                np.full(n, np.inf, F32),
                [np.zeros(n, F32) for _ in range(3)],
                np.zeros((n, 3), F32),
            )
        return buf

    @staticmethod
    def _add_cylinder(objs: list, a: np.ndarray, b: np.ndarray, r: float, caps: bool, albedo: np.ndarray) -> None:
        """Queue a cylinder from ``a`` to ``b`` (camera frame), clipped to stay in
        front of the camera (parts within ``NEAR_M + r`` of its plane are not drawn)."""
        near = r + NEAR_M
        if a[2] < near and b[2] < near:
            return
        if a[2] < near or b[2] < near:
            if a[2] < near:
                a, b = b, a
            b = a + (b - a) * ((a[2] - near) / (a[2] - b[2]))
            caps = False
        L = float(np.linalg.norm(b - a))
        if L < 1e-6:
            return
        objs.append(("cyl", _box(np.array([a, b]), r), (a + b) / 2, (b - a) / L, r, L / 2, caps, albedo))
