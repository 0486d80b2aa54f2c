"""One 10 ms step of the full vehicle: DCL, thrusters, 6-DOF rigid body (compiled).

Everything here runs once per simulator step, so it is one Numba function on
flat arrays (:func:`full_step`); :class:`sim_backend.full_vehicle.FullVehicle`
prepares the arrays and documents the physics. Layout of the scalar array
``c`` is given by the ``C_*`` indices below; of the state arrays by their
docstrings in ``FullVehicle``.

Order inside a step (time ``t`` -> ``t + h``):

1. DCL (vehicle velocity loops) on the measurements of time ``t``: velocity
   estimate (gyro through a first-order filter for p, q, r; u, v, w: the last
   DVL ping, or without a DVL the nominal model's prediction, corrected for
   heave by a depth-sensor observer), per-DOF PI + feedforward (nominal damping at the reference,
   nominal buoyancy and restoring), torque-first allocation, nominal thrust
   curve inverted into commands;
2. thrusters: dead zone, propeller speed lag, quadratic thrust with the true
   per-thruster gains;
3. rigid body: ``(M_bb(q) + M_A) nu_dot = tau_thr + tau_hydro + tau_restoring
   + tau_dist + tau_hold - b`` where ``M_bb`` is the vehicle + locked arm
   inertia and ``b = h_b + M_bq qddot`` the arm coupling and Coriolis terms
   (:mod:`sim_backend.coupling_kernel`, or the hull's own rigid-body Coriolis
   without coupling);
   semi-implicit Euler;
4. pose: Euler-angle rates and mid-step rotation, pool walls stop motion into them;
5. navigation dead reckoning of x, y with the DCL's linear velocity estimate.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from kcl.jit import drop_stale

from . import ardusub_kernel, coupling_kernel, sensor_kernel, step_kernel, thrusters

# the compiled step inlines the thrusters' functions, the coupling's terms, the AHRS and
# the arm's layouts: recompile when those files change (Numba's cache only watches this file)
drop_stale(
    __file__,
    [
        __file__,
        sensor_kernel.__file__,
        thrusters.__file__,
        coupling_kernel.__file__,
        step_kernel.__file__,
        ardusub_kernel.__file__,
    ],
)

from .ardusub_kernel import N_A as N_AP_CONST  # noqa: E402
from .ardusub_kernel import N_Z as N_AP_STATE  # noqa: E402
from .ardusub_kernel import Z_ACC_MEAS, ardusub_step  # noqa: E402
from .coupling_kernel import N_G, coupling_step  # noqa: E402
from .sensor_kernel import A_ATT, A_POS, A_RATES, ahrs_sample  # noqa: E402
from .step_kernel import R_Q, R_QDDOT, R_QDOT, R_QDOT_PREV, arm_step  # noqa: E402
from .thrusters import allocate, command_for_thrust, speed_for_command, thrust_for_speed  # noqa: E402

# --- indices into the scalar array ``c``
C_BG_B = 0  # BG * buoyancy (N m)
C_NET_B = 1  # true net buoyancy (N, up)
C_NET_B_NOM = 2  # nominal net buoyancy (N)
C_HAS_DVL = 3  # 1: the DCL closes u, v, w on the DVL
C_L1 = 4  # depth observer gains per step: position,
C_L2 = 5  # velocity (1/s),
C_L3 = 14  # acceleration bias (1/s^2)
C_DVL_STALE = 15  # s: a DVL silent this long is not used
C_GYRO_W = 6  # DCL gyro filter cutoff (rad/s)
C_THR_TAU = 7  # thruster lag (s)
C_DEAD = 8  # dead zone
C_FMAX = 9
C_RMAX = 10
C_HOLD = 11  # 1: diver holds the vehicle
C_COUPLED = 12  # 1: M_bb and b come from the coupling (coupling_kernel); 0: hull only
C_THRUSTERS_ON = 13  # 0: thrusters off (no actuated DOF)
C_AUTOPILOT = 16  # 1: ArduSub in GUIDED (sim_backend.ardusub) instead of the MARIS DCL
N_SCALARS = 17

# --- indices into the per-DOF table ``k`` (rows), columns are the 6 DOFs
(
    K_RIGID,
    K_ADDED,
    K_LIN,
    K_QUAD,
    K_MNOM,
    K_LIN_NOM,
    K_QUAD_NOM,
    K_KP,
    K_KI,
    K_TAUMAX,
    K_VMAX,
    K_ACT,
    K_HOLD_K,
    K_HOLD_C,
) = range(14)
N_K_ROWS = 14

# --- state vector ``s`` (besides nu, eta): estimates and controller memory
S_VHAT = 0  # 6: DCL velocity estimate
S_INT = 6  # 6: PI integrals
S_DIST = 12  # 6: disturbance wrench (N, N m)
S_ZHAT = 18  # depth observer position (m)
S_NAV = 19  # 2: dead-reckoned x, y (m)
S_LAST_DVL_T = 21  # time of the last DVL ping used
S_BIAS = 22  # depth observer: heave acceleration bias (m/s^2)
S_AP = 23  # the ArduSub controller's state (sim_backend.ardusub_kernel Z_* layout)
N_STATE = S_AP + N_AP_STATE


# --- packed call (few arguments: Numba's dispatcher checks each one on every call)
# inputs ``x``
X_VREF, X_GYRO, X_DEPTH, X_DVL_T, X_DVL_V, X_NOISE, X_OU_A, X_T, X_H, X_CUR = 0, 6, 9, 10, 11, 14, 20, 21, 22, 23
# the command (after saturation), the velocity limits, 1/0 actuated DOFs (vehicle_command)
X_CMD, X_VMAX, X_ACT = 26, 32, 38
X_ATT = 44  # the AHRS attitude (rad; NaN: none) for the ArduSub controller
N_X = 47
# constant vectors appended to the scalars ``c``
C_GAINS = N_SCALARS
C_BOUNDS = C_GAINS + 8
C_ETA0 = C_BOUNDS + 6
C_OU_B = C_ETA0 + 6
C_AP = C_OU_B + 6  # the ArduSub controller's constants (sim_backend.ardusub_kernel A_* layout)
N_C = C_AP + N_AP_CONST
# state ``S``: nu, eta, estimator/controller state, propeller speeds, thrusts, wrench demand
S_NU, S_ETA, S_S, S_N, S_THRUST, S_TAU = 0, 6, 12, 12 + N_STATE, 20 + N_STATE, 28 + N_STATE
S_MB = S_TAU + 6  # 42: the coupling's M_bb (6, 6, row-major), then b (6)
N_S = S_MB + 42
# the constants in one array ``KC`` (coupled_step): k (N_K_ROWS, 6), c, B (6, 8), Binv (8, 6), row-major
KC_K = 0
KC_C = KC_K + N_K_ROWS * 6
KC_B = KC_C + N_C
KC_BINV = KC_B + 48
KC_APAR = KC_BINV + 48  # the AHRS's parameters (sim_backend.sensor_kernel P_* layout)
N_KC = KC_APAR + sensor_kernel.N_P


@njit(cache=True)
def vehicle_command(v: np.ndarray, x: np.ndarray) -> bool:
    """Body velocity reference ``v`` (6,) into the command of the inputs ``x``
    (``X_CMD``: non-finite values count as zero, clipped to ``X_VMAX``) and the
    reference ``X_VREF`` (the command, zero on DOFs not actuated: ``X_ACT`` 0/1).
    Returns whether ``v`` was all finite."""
    vmax, actuated, command, vref = (
        x[X_VMAX : X_VMAX + 6],
        x[X_ACT : X_ACT + 6],
        x[X_CMD : X_CMD + 6],
        x[X_VREF : X_VREF + 6],
    )
    finite = True
    for i in range(6):
        vi = v[i]
        if not np.isfinite(vi):
            vi = 0.0
            finite = False
        m = vmax[i]
        c = m if vi > m else (-m if vi < -m else vi)
        command[i] = c
        vref[i] = c if actuated[i] > 0.5 else 0.0
    return finite


@njit(cache=True)
def coupled_step(
    x, A, CPW, first, ahrs, ahrs_ok, dvl_t, dvl_v, noise, ni, KC, S, sample_t, abuf, ai, alpha, enabled, idle
):
    """One step of the arm and the full vehicle with the arm's coupling, in one call
    (fewer arguments for Numba's dispatcher to check): first the arm's
    (:func:`sim_backend.step_kernel.arm_step` with ``alpha``, ``enabled``,
    ``idle``: :class:`sim_backend.arm_sim.ArmJoints`), then the coupling's terms
    (:func:`sim_backend.coupling_kernel.coupling_step` on the arm's state array
    ``A``, :mod:`sim_backend.step_kernel` rows; ``first``: the first step; the
    model and scratch ``CPW``: :class:`sim_backend.coupling.ArmCoupling`) into
    ``S`` (``S_MB``: ``M_bb``, then ``b``), then :func:`packed_step` with the
    constants ``KC`` (``KC_*`` layout), then, when ``sample_t >= 0``, the AHRS
    sample of that time (s) into its state ``ahrs``
    (:func:`sim_backend.sensor_kernel.ahrs_sample` with the normals
    ``abuf[ai:ai + 13]`` and the parameters in ``KC``, on the new pose, velocity,
    thruster activity and dead-reckoned position). Returns the thruster activity."""
    arm_step(x[X_H], alpha, enabled, idle, A)
    Mbb, bias = S[S_MB : S_MB + 36].reshape((6, 6)), S[S_MB + 36 : S_MB + 42]
    coupling_step(
        x[X_H],
        A[R_Q],
        A[R_QDOT],
        A[R_QDOT_PREV],
        A[R_QDDOT],
        S[S_NU : S_NU + 6],
        first,
        CPW[:, :N_G],
        CPW[:, N_G:],
        Mbb,
        bias,
    )
    k = KC[KC_K:KC_C].reshape((N_K_ROWS, 6))
    B = KC[KC_B:KC_BINV].reshape((6, 8))
    Binv = KC[KC_BINV:KC_APAR].reshape((8, 6))
    level = packed_step(x, Mbb, bias, ahrs, ahrs_ok, dvl_t, dvl_v, noise, ni, k, KC[KC_C:KC_B], B, Binv, S)
    if sample_t >= 0.0:
        ahrs_sample(
            sample_t,
            S[S_ETA : S_ETA + 6],
            S[S_NU : S_NU + 6],
            level,
            S[S_S + S_NAV : S_S + S_NAV + 2],
            True,
            abuf,
            ai,
            ahrs,
            KC[KC_APAR:N_KC],
        )
    return level


@njit(cache=True)
def packed_step(x, Mbb, bias, ahrs, ahrs_ok, dvl_t, dvl_v, noise, ni, k, c, B, Binv, S):
    """:func:`full_step` on packed arrays (layouts: the ``X_*``, ``C_*``, ``S_*`` indices).

    ``bias``: the coupling's ``b`` (its first 6 entries; Pinocchio's whole ``tau``
    may be passed); ``ahrs``: the AHRS state array (:mod:`sim_backend.sensor_kernel`:
    gyro rates and depth), used when ``ahrs_ok`` (otherwise the DCL holds still:
    zero rates, the depth observer's own depth); ``dvl_t``: time of the last DVL
    ping (-inf: none), ``dvl_v`` (3,) its velocity; ``noise[ni:ni + 6]``: the
    disturbance's standard normals."""
    if ahrs_ok:
        for i in range(3):
            x[X_GYRO + i] = ahrs[A_RATES + i]
            x[X_ATT + i] = ahrs[A_ATT + i]
        x[X_DEPTH] = ahrs[A_POS + 2]
    else:
        for i in range(3):
            x[X_GYRO + i] = 0.0
            x[X_ATT + i] = math.nan
        x[X_DEPTH] = S[S_S + S_ZHAT]
    x[X_DVL_T] = dvl_t
    if dvl_t != -math.inf:
        for i in range(3):
            x[X_DVL_V + i] = dvl_v[i]
    for i in range(6):
        x[X_NOISE + i] = noise[ni + i]
    return full_step(
        x[X_H],
        x[X_T],
        x[X_VREF : X_VREF + 6],
        x[X_GYRO : X_GYRO + 3],
        x[X_DEPTH],
        x[X_DVL_T],
        x[X_DVL_V : X_DVL_V + 3],
        Mbb,
        bias[:6],
        x[X_NOISE : X_NOISE + 6],
        x[X_OU_A],
        c[C_OU_B : C_OU_B + 6],
        x[X_CUR : X_CUR + 3],
        c[C_ETA0 : C_ETA0 + 6],
        c[C_BOUNDS : C_BOUNDS + 6],
        k,
        c,
        B,
        Binv,
        c[C_GAINS : C_GAINS + 8],
        S[S_NU : S_NU + 6],
        S[S_ETA : S_ETA + 6],
        S[S_S : S_S + N_STATE],
        S[S_N : S_N + 8],
        S[S_THRUST : S_THRUST + 8],
        S[S_TAU : S_TAU + 6],
        x[X_ATT : X_ATT + 3],
    )


@njit(cache=True)
def _solve6(A: np.ndarray, b: np.ndarray, x: np.ndarray) -> None:
    """x = A^-1 b for a 6x6 symmetric positive definite A (Gaussian elimination, partial pivoting)."""
    M = A.copy()
    y = b.copy()
    n = 6
    for col in range(n):
        piv = col
        best = abs(M[col, col])
        for r in range(col + 1, n):
            if abs(M[r, col]) > best:
                best = abs(M[r, col])
                piv = r
        if piv != col:
            for k in range(n):
                tmp = M[col, k]
                M[col, k] = M[piv, k]
                M[piv, k] = tmp
            tmp = y[col]
            y[col] = y[piv]
            y[piv] = tmp
        d = M[col, col]
        for r in range(col + 1, n):
            f = M[r, col] / d
            if f != 0.0:
                for k in range(col, n):
                    M[r, k] -= f * M[col, k]
                y[r] -= f * y[col]
    for r in range(n - 1, -1, -1):
        acc = y[r]
        for k in range(r + 1, n):
            acc -= M[r, k] * x[k]
        x[r] = acc / M[r, r]


@njit(cache=True)
def _rotation(roll: float, pitch: float, yaw: float, R: np.ndarray) -> None:
    cr, sr = math.cos(roll), math.sin(roll)
    cp, sp = math.cos(pitch), math.sin(pitch)
    cy, sy = math.cos(yaw), math.sin(yaw)
    R[0, 0] = cy * cp
    R[0, 1] = cy * sp * sr - sy * cr
    R[0, 2] = cy * sp * cr + sy * sr
    R[1, 0] = sy * cp
    R[1, 1] = sy * sp * sr + cy * cr
    R[1, 2] = sy * sp * cr - cy * sr
    R[2, 0] = -sp
    R[2, 1] = cp * sr
    R[2, 2] = cp * cr


@njit(cache=True)
def _restoring(eta: np.ndarray, bgb: float, net_b: float, out: np.ndarray) -> None:
    """Hydrostatic wrench (6,) on the hull (body frame): net buoyancy up (world -z)
    and the righting moments of the centre of buoyancy BG above the centre of gravity."""
    roll, pitch = eta[3], eta[4]
    cr, sr = math.cos(roll), math.sin(roll)
    cp, sp = math.cos(pitch), math.sin(pitch)
    # world up-force (0, 0, -net_b) in body axes: R^T (0, 0, -net_b)
    out[0] = net_b * sp
    out[1] = -net_b * cp * sr
    out[2] = -net_b * cp * cr
    out[3] = -bgb * cp * sr
    out[4] = -bgb * sp
    out[5] = 0.0


@njit(cache=True)
def full_step(
    h,
    t,
    vref,
    gyro,
    depth,
    dvl_t,
    dvl_v,
    Mbb,
    bias,
    noise6,
    ou_a,
    ou_b,
    cur_world,
    eta0,
    bounds,
    k,
    c,
    B,
    Binv,
    gains,
    nu,
    eta,
    s,
    n,
    thrust,
    tau_cmd,
    att,
):
    """Advance the vehicle ``h`` seconds from time ``t`` (s, the DVL's clock) (see the
    module docstring; with ``c[C_AUTOPILOT]``, ArduSub's controllers replace the DCL:
    :mod:`sim_backend.ardusub`, reading the AHRS attitude ``att`` (3,)). In place:
    ``nu`` (6) body velocity, ``eta`` (6) pose, ``s`` (N_STATE) estimator and
    controller state, ``n`` (8) propeller speeds, ``thrust`` (8) N, ``tau_cmd`` (6)
    the DCL's wrench demand. Returns the RMS normalized propeller speed (0..1)."""
    R = np.empty((3, 3))
    _rotation(eta[3], eta[4], eta[5], R)
    g_nom = np.empty(6)
    _restoring(eta, c[C_BG_B], c[C_NET_B_NOM], g_nom)
    vhat = s[S_VHAT : S_VHAT + 6]
    # ---------------------------------------------------------------- 1. DCL
    # angular rates: gyro through the vehicle's first-order filter
    ag = 1.0 - math.exp(-c[C_GYRO_W] * h)
    for i in range(3):
        vhat[3 + i] += ag * (gyro[i] - vhat[3 + i])
    # linear with a DVL: the last ping, held until the next one; a DVL silent for
    # longer than C_DVL_STALE is dropped and the model estimate takes over from there
    if c[C_HAS_DVL] > 0.5 and dvl_t > s[S_LAST_DVL_T]:
        s[S_LAST_DVL_T] = dvl_t
        for i in range(3):
            vhat[i] = dvl_v[i]
    has_dvl = c[C_HAS_DVL] > 0.5 and t - s[S_LAST_DVL_T] <= c[C_DVL_STALE]
    if has_dvl:  # keep the depth observer on the measurement, ready if the DVL drops
        s[S_ZHAT] = depth
        s[S_BIAS] = 0.0
    tau_dem = np.zeros(6)
    alloc = np.zeros(8)
    fmax, rmax = c[C_FMAX], c[C_RMAX]
    if c[C_AUTOPILOT] > 0.5:  # ArduSub: the thrust each ESC is driven to; tau_cmd its wrench
        if c[C_THRUSTERS_ON] > 0.5:
            ardusub_step(
                h, vref, gyro, att, depth, vhat, c[C_AP : C_AP + N_AP_CONST], s[S_AP : S_AP + N_AP_STATE], alloc
            )
        for i in range(6):
            for j in range(8):
                tau_dem[i] += B[i, j] * alloc[j]
        for i in range(6):
            tau_cmd[i] = tau_dem[i]
    else:
        if c[C_THRUSTERS_ON] > 0.5:
            for i in range(6):
                if k[K_ACT, i] < 0.5:
                    continue
                r = vref[i]
                e = r - vhat[i]
                integ = s[S_INT + i] + e * h
                lim = k[K_TAUMAX, i] / max(k[K_KI, i], 1e-12)
                if integ > lim:
                    integ = lim
                elif integ < -lim:
                    integ = -lim
                s[S_INT + i] = integ
                ff = k[K_LIN_NOM, i] * r + k[K_QUAD_NOM, i] * r * abs(r) - g_nom[i]
                tau_dem[i] = ff + k[K_KP, i] * e + k[K_KI, i] * integ
        for i in range(6):
            tau_cmd[i] = tau_dem[i]
        allocate(tau_dem, Binv, fmax, rmax, alloc)
    if not has_dvl:
        # without a DVL: the nominal model predicts what the allocated thrust does ...
        tau_exp = np.zeros(6)
        for i in range(3):
            for j in range(8):
                tau_exp[i] += B[i, j] * alloc[j]
        acc_w = 0.0
        for i in range(3):
            v = vhat[i]
            acc = (tau_exp[i] + g_nom[i] - k[K_LIN_NOM, i] * v - k[K_QUAD_NOM, i] * v * abs(v)) / k[K_MNOM, i]
            if i == 2:
                acc_w = acc
            else:
                vhat[i] = v + acc * h
        # ... and heave is corrected by the depth sensor: third-order observer (depth,
        # heave rate, acceleration bias), small attitudes: body w ~ world z rate
        ez = depth - s[S_ZHAT]
        s[S_ZHAT] += h * vhat[2] + c[C_L1] * ez
        vhat[2] += h * (acc_w + s[S_BIAS]) + c[C_L2] * ez
        s[S_BIAS] += c[C_L3] * ez
    # ---------------------------------------------------------------- 2. thrusters
    at = 1.0 - math.exp(-h / c[C_THR_TAU]) if c[C_THR_TAU] > 0.0 else 1.0
    ms = 0.0
    for j in range(8):
        target = (
            speed_for_command(command_for_thrust(alloc[j], fmax, rmax), c[C_DEAD]) if c[C_THRUSTERS_ON] > 0.5 else 0.0
        )
        n[j] += at * (target - n[j])
        thrust[j] = thrust_for_speed(n[j], gains[j], fmax, rmax)
        ms += n[j] * n[j]
    tau = np.zeros(6)
    for i in range(6):
        for j in range(8):
            tau[i] += B[i, j] * thrust[j]
    # ---------------------------------------------------------------- 3. rigid body
    g_true = np.empty(6)
    _restoring(eta, c[C_BG_B], c[C_NET_B], g_true)
    vr = nu.copy()  # velocity relative to the water
    for i in range(3):
        vr[i] -= R[0, i] * cur_world[0] + R[1, i] * cur_world[1] + R[2, i] * cur_world[2]
    for i in range(6):
        s[S_DIST + i] = ou_a * s[S_DIST + i] + ou_b[i] * noise6[i]
        tau[i] += g_true[i] + s[S_DIST + i] - k[K_LIN, i] * vr[i] - k[K_QUAD, i] * vr[i] * abs(vr[i])
    if c[C_HOLD] > 0.5:  # a diver's hands: spring-damper towards the pose where he holds it
        dw = np.empty(3)
        for i in range(3):
            dw[i] = eta[i] - eta0[i]
        for i in range(3):  # world displacement into body axes
            db = R[0, i] * dw[0] + R[1, i] * dw[1] + R[2, i] * dw[2]
            tau[i] -= k[K_HOLD_K, i] * db + k[K_HOLD_C, i] * nu[i]
        dyaw = (eta[5] - eta0[5] + math.pi) % (2.0 * math.pi) - math.pi
        tau[5] -= k[K_HOLD_K, 5] * dyaw + k[K_HOLD_C, 5] * nu[5]
    M = np.empty((6, 6))
    rhs = np.empty(6)
    if c[C_COUPLED] > 0.5:  # Mbb: upper triangle of a symmetric matrix
        for i in range(6):
            for j in range(6):
                M[i, j] = Mbb[i, j] if i <= j else Mbb[j, i]
            rhs[i] = tau[i] - bias[i]
    else:  # hull alone: diagonal rigid body, Coriolis m (w x v), w x (I w)
        for i in range(6):
            for j in range(6):
                M[i, j] = 0.0
            M[i, i] = k[K_RIGID, i]
        u, v, w, p, q, r = nu[0], nu[1], nu[2], nu[3], nu[4], nu[5]
        m = k[K_RIGID, 0]
        ix, iy, iz = k[K_RIGID, 3], k[K_RIGID, 4], k[K_RIGID, 5]
        cor = (
            m * (q * w - r * v),
            m * (r * u - p * w),
            m * (p * v - q * u),
            (iz - iy) * q * r,
            (ix - iz) * r * p,
            (iy - ix) * p * q,
        )
        for i in range(6):
            rhs[i] = tau[i] - cor[i]
    for i in range(6):
        M[i, i] += k[K_ADDED, i]
    acc6 = np.empty(6)
    _solve6(M, rhs, acc6)
    for i in range(6):
        nu[i] += h * acc6[i]
    s[S_AP + Z_ACC_MEAS] = acc6[2]  # what ArduSub's accelerometer sees of the heave (next step)
    # ---------------------------------------------------------------- 4. pose
    x, y, z, roll, pitch, yaw = eta[0], eta[1], eta[2], eta[3], eta[4], eta[5]
    u, v, w, p, q, r = nu[0], nu[1], nu[2], nu[3], nu[4], nu[5]
    cr, sr, cp = math.cos(roll), math.sin(roll), math.cos(pitch)
    if abs(cp) < 1e-6:
        cp = 1e-6 if cp >= 0.0 else -1e-6
    tp = math.sin(pitch) / cp
    roll2 = roll + (p + (sr * q + cr * r) * tp) * h
    pitch2 = pitch + (cr * q - sr * r) * h
    yaw2 = yaw + ((sr * q + cr * r) / cp) * h
    _rotation(0.5 * (roll + roll2), 0.5 * (pitch + pitch2), 0.5 * (yaw + yaw2), R)
    pos = np.empty(3)
    pos[0], pos[1], pos[2] = x, y, z
    for i in range(3):
        pos[i] += (R[i, 0] * u + R[i, 1] * v + R[i, 2] * w) * h
    for i in range(3):
        lo, hi = bounds[2 * i], bounds[2 * i + 1]
        if pos[i] < lo or pos[i] > hi:  # pool wall, floor or surface: motion into it stops
            outward = -1.0 if pos[i] < lo else 1.0
            pos[i] = lo if pos[i] < lo else hi
            comp = R[i, 0] * nu[0] + R[i, 1] * nu[1] + R[i, 2] * nu[2]
            if comp * outward > 0.0:
                for j in range(3):
                    nu[j] -= comp * R[i, j]
    eta[0], eta[1], eta[2] = pos[0], pos[1], pos[2]
    eta[3], eta[4] = roll2, pitch2
    eta[5] = (yaw2 + math.pi) % (2.0 * math.pi) - math.pi
    # ---------------------------------------------------------------- 5. navigation
    for i in range(2):
        s[S_NAV + i] += (R[i, 0] * vhat[0] + R[i, 1] * vhat[1] + R[i, 2] * vhat[2]) * h
    return math.sqrt(ms / 8.0)
