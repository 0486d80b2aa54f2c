"""Kinematic vehicle with imperfect velocity tracking (the MARIS failure cause).

The vehicle's own velocity loop (DCL + thruster allocation) is not simulated in
detail; what matters for the KCL above it is how the *actual* body velocity
differs from the *commanded* one. Per DOF (body frame FRD, [u v w p q r]):

1. saturation: the command is clipped to ``max_velocity``;
2. dead band: commands smaller than ``dead_band`` produce nothing (thrusters do
   not spin up for tiny set-points);
3. poor tracking near zero: above the dead band the steady-state gain rises from
   ``low_speed_gain`` towards 1 as ``1 - (1 - g0) exp(-(|c| - dead_band) / low_speed_scale)``;
4. first-order lag with ``time_constant_s`` (0 = instantaneous);
5. an unmodelled disturbance (Ornstein-Uhlenbeck, std ``disturbance_std``,
   correlation time ``disturbance_time_s``) and the water current, of which the
   velocity loop rejects the fraction ``current.rejection``.

Non-actuated DOFs ignore commands; roll and pitch then come back to level like a
damped pendulum (metacentric restoring, ``restoring_period_s``, ``restoring_damping``),
the others decay to zero with their time constant. Actuated roll and pitch feel
the same restoring moment, which their velocity loop partly fights.

The pose ``eta = [x y z roll pitch yaw]`` (world NED, rad) integrates the actual
body velocity. With zero time constants, dead bands, disturbance and current and
unit low-speed gains the vehicle follows its command exactly ("perfect tracking").
"""

from __future__ import annotations

import math

import numpy as np

from .geometry import rotation_rpy, wrap_angle


class VehicleDynamics:
    """State: ``eta`` (6,) world pose, ``nu`` (6,) actual body velocity (ground
    relative), ``command`` (6,) last reference after saturation. Units SI / rad.

    The arithmetic is done on Python floats, DOF by DOF: for six numbers that costs
    less than numpy's per-call overhead, and this runs every simulated step.
    """

    def __init__(
        self,
        params: dict,
        eta0: np.ndarray,
        current_world: np.ndarray,
        bounds: tuple[tuple[float, float], ...] | None = None,
    ):
        #: (low, high) limits of x, y, z (m) for the reference point; motion stops there.
        self.bounds = bounds or ((-math.inf, math.inf),) * 3
        self.actuated = tuple(bool(b) for b in params["vehicle.actuated"])
        self.tau = tuple(float(x) for x in params["vehicle.time_constant_s"])
        self.vmax = tuple(float(x) for x in params["vehicle.max_velocity"])
        self.dead_band = tuple(float(x) for x in params["vehicle.dead_band"])
        self.g0 = tuple(float(x) for x in params["vehicle.low_speed_gain"])
        self.scale = tuple(float(x) for x in params["vehicle.low_speed_scale"])
        self.dist_std = tuple(float(x) for x in params["vehicle.disturbance_std"])
        self.dist_time = float(params["vehicle.disturbance_time_s"])
        wn = 2.0 * math.pi / float(params["vehicle.restoring_period_s"])
        self.wn2 = wn * wn
        self.two_zeta_wn = 2.0 * float(params["vehicle.restoring_damping"]) * wn
        self.current_world = tuple(float(x) for x in current_world)
        self.current_pass = 1.0 - float(params["current.rejection"])
        self.has_disturbance = any(x > 0.0 for x in self.dist_std)
        self.has_current = any(x != 0.0 for x in self.current_world) and self.current_pass > 0.0
        self.eta = np.array(eta0, dtype=float)
        self.nu = np.zeros(6)  # actual body velocity, last step
        self.command = np.zeros(6)
        self._nt = [0.0] * 6  # velocity produced by the thrusters (water relative)
        self._dist = [0.0] * 6
        self._ref = [0.0] * 6
        self._h = -1.0
        self.set_command(np.zeros(6))

    # ---------------------------------------------------------------- inputs

    def set_command(self, v: np.ndarray | list[float]) -> bool:
        """Body velocity reference (6,); non-finite values are treated as zero.
        Returns whether ``v`` was all finite."""
        cmd = [0.0] * 6
        finite = True
        values = v if isinstance(v, list) else np.asarray(v, dtype=float).reshape(6).tolist()
        for i, c in enumerate(values):
            if not math.isfinite(c):
                c = 0.0
                finite = False
            vmax = self.vmax[i]
            c = vmax if c > vmax else (-vmax if c < -vmax else c)
            cmd[i] = c
            mag = abs(c)
            db = self.dead_band[i]
            if mag <= db or not self.actuated[i]:
                self._ref[i] = 0.0
            else:
                self._ref[i] = c * (1.0 - (1.0 - self.g0[i]) * math.exp(-(mag - db) / self.scale[i]))
        self.command = np.array(cmd)
        return finite

    def activity(self) -> float:
        """Stand-in for thruster activity (0..1), for the gyro's vibration line: the
        RMS of the actuated commands over their limits (this model has no thrusters)."""
        acc, k = 0.0, 0
        for c, m, a in zip(self.command.tolist(), self.vmax, self.actuated):
            if a and m > 0.0:
                acc += (c / m) ** 2
                k += 1
        return math.sqrt(acc / k) if k else 0.0

    # ---------------------------------------------------------------- integration

    def _coefficients(self, h: float) -> None:
        self._h = h
        self._alpha = [1.0 - math.exp(-h / tau) if tau > 0.0 else 1.0 for tau in self.tau]
        for i in (3, 4):  # pendulum DOFs integrate their own dynamics
            if not self.actuated[i]:
                self._alpha[i] = 0.0
        a = math.exp(-h / self.dist_time)
        self._ou_a = a
        self._ou_b = [sd * math.sqrt(max(0.0, 1.0 - a * a)) for sd in self.dist_std]

    def step(self, h: float, normals6: list[float] | None) -> None:
        """Advance ``h`` seconds; ``normals6`` are 6 standard normal samples for the
        disturbance (None when the scenario has no disturbance)."""
        if h != self._h:
            self._coefficients(h)
        nt, ref, alpha = self._nt, self._ref, self._alpha
        x, y, z, roll, pitch, yaw = self.eta.tolist()
        for i in range(6):
            nt[i] += (ref[i] - nt[i]) * alpha[i]
        # roll / pitch: hydrostatic restoring moment (metacentric height). Without
        # actuation a damped pendulum; with actuation the velocity loop (lag
        # above) fights it and it only pulls the attitude back to level.
        for i, ang in ((3, roll), (4, pitch)):
            if self.actuated[i]:
                nt[i] -= self.wn2 * ang * h
            else:
                nt[i] -= (self.wn2 * ang + self.two_zeta_wn * nt[i]) * h
        nu = list(nt)
        if self.has_disturbance and normals6 is not None:
            d, a, b = self._dist, self._ou_a, self._ou_b
            for i in range(6):
                d[i] = d[i] * a + b[i] * normals6[i]
                nu[i] += d[i]
        if self.has_current:
            R = rotation_rpy(roll, pitch, yaw)
            cb = R.T @ np.array(self.current_world)
            for i in range(3):
                nu[i] += self.current_pass * float(cb[i])
        u, v, w, p, q, r = nu
        # attitude first (Euler-angle rates), then position with the mid-step rotation
        cr, sr, cp = math.cos(roll), math.sin(roll), math.cos(pitch)
        if abs(cp) < 1e-6:
            cp = math.copysign(1e-6, cp)
        tp = math.sin(pitch) / cp
        roll2 = roll + (p + (sr * q + cr * r) * tp) * h
        pitch2 = pitch + (cr * q - sr * r) * h
        yaw2 = yaw + ((sr * q + cr * r) / cp) * h
        mr, mp, my = 0.5 * (roll + roll2), 0.5 * (pitch + pitch2), 0.5 * (yaw + yaw2)
        cr, sr = math.cos(mr), math.sin(mr)
        cp, sp = math.cos(mp), math.sin(mp)
        cy, sy = math.cos(my), math.sin(my)
        x += ((cy * cp) * u + (cy * sp * sr - sy * cr) * v + (cy * sp * cr + sy * sr) * w) * h
        y += ((sy * cp) * u + (sy * sp * sr + cy * cr) * v + (sy * sp * cr - cy * sr) * w) * h
        z += ((-sp) * u + (cp * sr) * v + (cp * cr) * w) * h
        pos = [x, y, z]
        for i in range(3):
            lo, hi = self.bounds[i]
            if pos[i] < lo or pos[i] > hi:  # pool wall, floor or surface: motion into it stops
                outward = -1.0 if pos[i] < lo else 1.0
                pos[i] = lo if pos[i] < lo else hi
                # row i of the mid-step rotation body -> world: world axis i in body axes
                row = (
                    (cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr),
                    (sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr),
                    (-sp, cp * sr, cp * cr),
                )[i]
                for vec in (self._nt, self._dist, nu):
                    _drop_outward(vec, row, outward)
        self.eta[:] = (pos[0], pos[1], pos[2], roll2, pitch2, wrap_angle(yaw2))
        self.nu[:] = nu


def _drop_outward(vec: list[float], normal_body: tuple[float, float, float], outward: float) -> None:
    """Remove, in place, the part of the linear body velocity ``vec[0:3]`` (m/s)
    that moves along the world axis ``normal_body`` (expressed in body axes) in
    the ``outward`` direction (+1 or -1): a wall stops motion into it, not along it."""
    c = vec[0] * normal_body[0] + vec[1] * normal_body[1] + vec[2] * normal_body[2]
    if c * outward > 0.0:
        for k in range(3):
            vec[k] -= c * normal_body[k]
