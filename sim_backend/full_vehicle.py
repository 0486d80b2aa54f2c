"""Full vehicle model: 6-DOF rigid body, thrusters, the vehicle's own velocity loops.

What the KCL's commanded body velocity turns into, following the MARIS control
chain below the KCL (maris.md: "Dynamic Control Layer: vehicle velocity PI +
feedforward per DOF"; "Thruster allocation: 4 vertical + 4 horizontal
thrusters, torque first"):

* **DCL** (:mod:`sim_backend.vehicle_kernel`): one PI regulator with feedforward
  per DOF, closed on the vehicle's *estimate* of its velocity: angular rates
  from the gyro; linear velocity from the DVL when there is one
  (``dvl.present``, the last ping held), otherwise from the nominal model's
  prediction of what the allocated thrust does, corrected only for heave, by
  the depth sensor. Without a DVL, surge and sway are the nominal model's
  prediction of what the thrusters do: a disturbance, a thruster that gives
  less than asked, or a model error moves the vehicle unseen. The gains come
  from the nominal model and ``dcl.bandwidth_rad_s`` (``Kp = 2 M w``,
  ``Ki = M w^2``: critically damped on the nominal model).
* **Thrusters** (:mod:`sim_backend.thrusters`): torque-first allocation with
  saturation, quadratic thrust, uncompensated dead zone, propeller lag, true
  gains spread around the nominal ones.
* **Rigid body** (:mod:`sim_backend.hydrodynamics`, :mod:`sim_backend.coupling`):
  rigid-body and added mass, linear + quadratic damping on the velocity
  relative to the water, restoring moments and net buoyancy, a slowly varying
  disturbance wrench (umbilical, unmodelled flow), and the arm's reaction
  (floating-base dynamics, :mod:`sim_backend.coupling_kernel`). A diver can hold the vehicle (``diver.hold``: MARIS October 2015).

Same interface as :class:`sim_backend.vehicle_dynamics.VehicleDynamics`
(``set_command``, ``step``, ``eta``, ``nu``, ``command``) plus the navigation
estimate ``nav_xy`` (dead reckoning with the DCL's velocity estimate) and the
thruster activity ``vibration_level`` (RMS normalized propeller speed) that
shakes the gyro. It reads the sensors (gyro, depth, DVL) and the arm through
:meth:`FullVehicle.bind`.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from . import ardusub_kernel as ak
from . import sensor_kernel as sk
from . import vehicle_kernel as vk
from .ardusub import explicit_geometry, pack_constants, thrust_limits
from .coupling import ArmCoupling
from .hydrodynamics import HullParams, hull_params
from .step_kernel import R_QDDOT, R_QDOT_PREV
from .thrusters import geometry, wrench_limits

#: A DVL silent this long (s) is dropped by the DCL, which goes on with its model
#: estimate (as the navigation marks the vehicle DEGRADED, sim_backend.devices).
DVL_STALE_S = 1.0
_SHAPE6 = (6,)


class FullVehicle:
    """State: ``eta`` (6,) world pose, ``nu`` (6,) body velocity, ``command`` (6,)
    the last reference after saturation, ``thrust`` (8,) N, ``tau_cmd`` (6,) the
    DCL's wrench demand, ``nav_xy`` (2,) dead-reckoned position (m)."""

    has_disturbance: bool

    def __init__(
        self,
        params: dict,
        seed: int,
        eta0: np.ndarray,
        current_world: np.ndarray,
        bounds: tuple[tuple[float, float], ...] | None = None,
        urdf_path: str | None = None,
    ):
        p = params
        hull = hull_params(p, seed)
        self.hull: HullParams = hull
        self.actuated = tuple(bool(b) for b in p["vehicle.actuated"])
        self.vmax = np.array(p["vehicle.max_velocity"], dtype=float)
        self._act = np.array(self.actuated, dtype=float)
        # one state array for the compiled step; the attributes are views into it
        self.S = S = np.zeros(vk.N_S)
        self.nu = S[vk.S_NU : vk.S_NU + 6]
        self.eta = S[vk.S_ETA : vk.S_ETA + 6]
        self.s = S[vk.S_S : vk.S_S + vk.N_STATE]
        self.n = S[vk.S_N : vk.S_N + 8]
        self.thrust = S[vk.S_THRUST : vk.S_THRUST + 8]
        self.tau_cmd = S[vk.S_TAU : vk.S_TAU + 6]
        self.eta[:] = eta0
        self.eta0 = self.eta.copy()
        self.x = np.zeros(vk.N_X)  # inputs of one step (reference, sensors, noise, time, command)
        self.command = self.x[vk.X_CMD : vk.X_CMD + 6]
        self.x[vk.X_VMAX : vk.X_VMAX + 6] = self.vmax
        self.x[vk.X_ACT : vk.X_ACT + 6] = self._act
        self.vibration_level = 0.0
        b = bounds or ((-math.inf, math.inf),) * 3
        self.bounds = np.array([b[0][0], b[0][1], b[1][0], b[1][1], b[2][0], b[2][1]], dtype=float)
        self.current_world = np.asarray(current_world, dtype=float).copy()
        self.x[vk.X_CUR : vk.X_CUR + 3] = self.current_world

        if p["thrusters.positions_m"] is not None:  # an explicit frame (sim_backend.ardusub), its motor order
            self.B = explicit_geometry(p["thrusters.positions_m"], p["thrusters.directions"])
        else:
            self.B = geometry(
                float(p["thrusters.horizontal_angle_rad"]),
                *p["thrusters.horizontal_position_m"],
                *p["thrusters.vertical_position_m"],
            )
        self.Binv = np.ascontiguousarray(np.linalg.pinv(self.B))
        fmax = float(p["thrusters.max_forward_n"])
        rmax = float(p["thrusters.max_reverse_n"])
        dead_zone = float(p["thrusters.dead_zone"])
        self.autopilot = p["vehicle.autopilot"]
        ap_constants = pack_constants(p) if self.autopilot == "ardusub_guided" else None
        if ap_constants is not None:
            # the table holds the whole curve, dead band included: the propeller lag works on the
            # speed that gives the table's thrust (sim_backend.thrusters.thrust_for_speed)
            fmax, rmax = thrust_limits(ap_constants)
            dead_zone = 0.0
        mnom = hull.nominal_inertia
        w = np.array(p["dcl.bandwidth_rad_s"], dtype=float)
        k = np.zeros((vk.N_K_ROWS, 6))
        k[vk.K_RIGID] = hull.rigid
        k[vk.K_ADDED] = hull.added
        k[vk.K_LIN] = hull.lin
        k[vk.K_QUAD] = hull.quad
        k[vk.K_MNOM] = mnom
        k[vk.K_LIN_NOM] = hull.lin_nominal
        k[vk.K_QUAD_NOM] = hull.quad_nominal
        k[vk.K_KP] = 2.0 * mnom * w
        k[vk.K_KI] = mnom * w * w
        k[vk.K_TAUMAX] = wrench_limits(self.B, fmax)
        k[vk.K_VMAX] = self.vmax
        k[vk.K_ACT] = np.array(self.actuated, dtype=float)
        self.held = bool(p["diver.hold"])
        if self.held:
            wn = 2.0 * math.pi / float(p["diver.period_s"])
            m_eff = hull.rigid + hull.added
            k[vk.K_HOLD_K] = m_eff * wn * wn
            k[vk.K_HOLD_C] = 2.0 * float(p["diver.damping_ratio"]) * m_eff * wn
        self.k = k
        h = float(p["sim.step_s"])
        wo = float(p["dcl.depth_observer_rad_s"])
        c = np.zeros(vk.N_C)
        c[vk.C_BG_B] = hull.bg_buoyancy
        c[vk.C_NET_B] = hull.net_buoyancy
        c[vk.C_NET_B_NOM] = float(p["vehicle.net_buoyancy_n"])
        c[vk.C_HAS_DVL] = 1.0 if p["dvl.present"] else 0.0
        c[vk.C_DVL_STALE] = DVL_STALE_S
        c[vk.C_L1] = min(1.0, 3.0 * wo * h)  # observer poles all at -wo
        c[vk.C_L2] = 3.0 * wo * wo * h
        c[vk.C_L3] = wo**3 * h
        c[vk.C_GYRO_W] = float(p["dcl.gyro_filter_rad_s"])
        c[vk.C_THR_TAU] = float(p["thrusters.time_constant_s"])
        c[vk.C_DEAD] = dead_zone
        c[vk.C_FMAX] = fmax
        c[vk.C_RMAX] = rmax
        if ap_constants is not None:
            c[vk.C_AUTOPILOT] = 1.0
            c[vk.C_AP : vk.C_AP + len(ap_constants)] = ap_constants
        c[vk.C_HOLD] = 1.0 if self.held else 0.0
        c[vk.C_THRUSTERS_ON] = 1.0 if any(self.actuated) else 0.0
        c[vk.C_GAINS : vk.C_GAINS + 8] = hull.thruster_gain
        c[vk.C_BOUNDS : vk.C_BOUNDS + 6] = self.bounds
        c[vk.C_ETA0 : vk.C_ETA0 + 6] = self.eta0
        self.c = c
        self.s[vk.S_ZHAT] = self.eta[2]
        self.s[vk.S_NAV : vk.S_NAV + 2] = self.eta[:2]
        self.s[vk.S_LAST_DVL_T] = -math.inf
        #: Dead-reckoned north, east position (m) of the vehicle's navigation (a view into the state).
        self.nav_xy = self.s[vk.S_NAV : vk.S_NAV + 2]
        self.dist_std = np.array(p["vehicle.disturbance_force_std"], dtype=float)
        self.dist_time = float(p["vehicle.disturbance_force_time_s"])
        self.has_disturbance = bool(np.any(self.dist_std > 0.0))
        self._h = -1.0
        self._t = 0.0  # s, simulated time (the backend's clock starts at 0 too)
        self.coupling = None
        if p["arm.coupling"] and urdf_path is not None:
            self.coupling = ArmCoupling(
                urdf_path,
                hull.rigid[0],
                tuple(p["vehicle.size_m"]),
                float(p["arm.link_added_mass_ratio"]),
                inertia=tuple(hull.rigid[3:]),
            )
            c[vk.C_COUPLED] = 1.0
        self._Mbb = np.diag(hull.rigid)  # only used with coupling (its upper triangle)
        #: M_bb (rows 0-5) and b (row 6) of the compiled coupling, written in place at each step (a view)
        self.MB = S[vk.S_MB : vk.S_MB + 42].reshape(7, 6)
        self._first = True
        # the constants in one array for the coupled step (vehicle_kernel.KC_*); k, c, B, Binv: views into it
        self.KC = KC = np.zeros(vk.N_KC)
        KC[vk.KC_K : vk.KC_C] = self.k.reshape(-1)
        KC[vk.KC_C : vk.KC_B] = self.c
        KC[vk.KC_B : vk.KC_BINV] = self.B.reshape(-1)
        KC[vk.KC_BINV : vk.KC_APAR] = self.Binv.reshape(-1)
        self.k = KC[vk.KC_K : vk.KC_C].reshape(vk.N_K_ROWS, 6)
        self.c = KC[vk.KC_C : vk.KC_B]
        self.B = KC[vk.KC_B : vk.KC_BINV].reshape(6, 8)
        self.Binv = KC[vk.KC_BINV : vk.KC_APAR].reshape(8, 6)
        self._no_noise = np.zeros(6)
        self._no_ahrs = np.zeros(sk.N_A)
        self._bias = np.zeros(6)  # b of the coupling (N, N m): M_bq qddot + h_b; unused without coupling
        self._ahrs: Any = None
        self._dvl: Any = None
        self._arm: Any = None

    # ---------------------------------------------------------------- wiring
    def bind(self, ahrs: Any, dvl: Any, arm: Any) -> None:
        """Give the DCL its sensors (``ahrs.rates``/``ahrs.depth``, ``dvl.t``/``dvl.velocity``)
        and the coupling its arm (``arm.q``, ``arm.qdot``)."""
        self._ahrs, self._dvl, self._arm = ahrs, dvl, arm
        if ahrs is not None:  # its parameters, for the coupled step's AHRS sample
            self.KC[vk.KC_APAR : vk.N_KC] = ahrs._par
        if arm is not None:  # the coupling's memory: rows of the arm's state array
            arm.A[R_QDOT_PREV] = arm.qdot
            arm.A[R_QDDOT] = 0.0

    def load_kernels(self) -> None:
        """Load (first time: compile) the compiled steps this vehicle calls, now and on
        scratch copies of its state, not at the first step of a run (whose wall time
        would include it). After :meth:`bind`."""
        x, S = self.x.copy(), self.S.copy()
        x[vk.X_H] = 0.01  # (a step length: the copy is never used)
        vk.vehicle_command(np.zeros(6), x)
        arm, cp, nn = self._arm, self.coupling, self._no_noise
        ahrs_st = self._no_ahrs.copy() if self._ahrs is None else self._ahrs._st.copy()
        if cp is not None and arm is not None:
            vk.coupled_step(
                x,
                arm.A.copy(),
                cp.cpw.copy(),
                True,
                ahrs_st,
                False,
                -math.inf,
                nn,
                nn,
                0,
                self.KC,
                S,
                -1.0,
                nn,
                0,
                0.5,
                arm.enabled,
                arm.idle,
            )
        else:
            vk.packed_step(
                x,
                self._Mbb.copy(),
                self._bias.copy(),
                ahrs_st,
                False,
                -math.inf,
                nn,
                nn,
                0,
                self.k,
                self.c,
                self.B,
                self.Binv,
                S,
            )

    @property
    def steps_arm(self) -> bool:
        """True when :meth:`step_drawn` steps the bound arm too (the coupled model)."""
        return self.coupling is not None and self._arm is not None

    @property
    def motor_outputs(self) -> np.ndarray | None:
        """ArduSub's motor outputs (8,) in [-1, 1] of the last step (motor order), None with the MARIS DCL."""
        if self.autopilot != "ardusub_guided":
            return None
        base = vk.S_AP + ak.Z_OUT
        return self.s[base : base + 8].copy()

    @property
    def velocity_estimate(self) -> np.ndarray:
        """The DCL's body velocity estimate (6,)."""
        return self.s[vk.S_VHAT : vk.S_VHAT + 6].copy()

    # ---------------------------------------------------------------- inputs
    def set_command(self, v: np.ndarray | list[float]) -> bool:
        """Body velocity reference (6,); non-finite values count as zero; clipped to
        ``vehicle.max_velocity``; non-actuated DOFs ignore it. ``command`` is updated
        in place. Returns whether ``v`` was all finite."""
        if type(v) is not np.ndarray or v.dtype != np.float64:
            v = np.asarray(v, dtype=float)
        if v.shape != _SHAPE6:
            v = v.reshape(6)
        return vk.vehicle_command(v, self.x)

    # ---------------------------------------------------------------- integration
    def step(self, h: float, normals6: list[float] | np.ndarray | None) -> None:
        """Advance ``h`` seconds (and the bound arm when :attr:`steps_arm`); ``normals6``:
        6 standard normal samples for the disturbance (None without disturbance)."""
        if normals6 is None:
            self.step_drawn(h, self._no_noise, 0)
        else:
            self.step_drawn(h, np.asarray(normals6, dtype=float), 0)

    def step_drawn(self, h: float, noise: np.ndarray, i: int, sample_t: float = -1.0) -> bool:
        """:meth:`step` with the disturbance's 6 standard normals at ``noise[i:i + 6]``
        (a :meth:`sim_backend.rng.NormalBlock.reserve`; zeros without disturbance).
        ``sample_t`` >= 0: the AHRS sample of that time (s) is due after the step; the
        coupled step takes it in the same compiled call (:meth:`Ahrs.begin_sample`),
        otherwise the caller's :meth:`Ahrs.update` does. Returns whether it took it.
        When :attr:`steps_arm`, the arm's step comes first in the same call (the
        caller must not step the arm)."""
        x = self.x
        if h != self._h:
            self._h = h
            a = math.exp(-h / self.dist_time)
            x[vk.X_OU_A] = a
            x[vk.X_H] = h
            self.c[vk.C_OU_B : vk.C_OU_B + 6] = self.dist_std * math.sqrt(max(0.0, 1.0 - a * a))
        ahrs, dvl, arm = self._ahrs, self._dvl, self._arm
        self._t += h
        x[vk.X_T] = self._t
        cp = self.coupling
        if ahrs is None:
            ahrs_st, ahrs_ok = self._no_ahrs, False
        else:
            ahrs_st, ahrs_ok = ahrs._st, ahrs.t is not None and not ahrs.nan_fault
        if dvl is not None and dvl.t is not None and dvl.present:
            dvl_t, dvl_v = dvl.t, dvl.velocity
        else:
            dvl_t, dvl_v = -math.inf, self._no_noise
        if cp is not None and arm is not None:
            if sample_t >= 0.0 and ahrs is not None:
                abuf, ai = ahrs.begin_sample(sample_t)
            else:
                sample_t, abuf, ai = -1.0, self._no_noise, 0
            self.vibration_level = vk.coupled_step(
                x,
                arm.A,
                cp.cpw,
                self._first,
                ahrs_st,
                ahrs_ok,
                dvl_t,
                dvl_v,
                noise,
                i,
                self.KC,
                self.S,
                sample_t,
                abuf,
                ai,
                arm.lag(h),
                arm.enabled,
                arm.idle,
            )
            self._first = False
            if sample_t >= 0.0:
                if ahrs.nan_fault:
                    ahrs.end_sample()
                return True
        else:
            self.vibration_level = vk.packed_step(
                x,
                self._Mbb,
                self._bias,
                ahrs_st,
                ahrs_ok,
                dvl_t,
                dvl_v,
                noise,
                i,
                self.k,
                self.c,
                self.B,
                self.Binv,
                self.S,
            )
        return False
