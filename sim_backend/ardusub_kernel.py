"""ArduSub in GUIDED below the KCL, compiled: one controller step per simulator step.

:mod:`sim_backend.ardusub` says what is modelled and why; this module holds the
layouts and the compiled step (:func:`ardusub_step`), inlined by the full
vehicle's step (:mod:`sim_backend.vehicle_kernel`). Units inside: SI, radians,
NED/FRD (down positive): ArduSub's up-positive climb and throttle are turned
into down-positive values on entry and back for the mixer.

Constants ``a`` (``A_*``), state ``z`` (``Z_*``): flat float64 arrays, the
constants a block of the full vehicle's scalars, the state a block of its state.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

GRAVITY = 9.80665  # m/s^2, ArduPilot's GRAVITY_MSS

# --- constants ``a``
A_ANG_P = 0  # roll/pitch angle P (1/s)
A_ANG_Y_P = 1  # yaw angle P (1/s)
A_RP = 2  # 5: roll/pitch rate PID: P, I, D, IMAX, filter (rad/s)
A_Y = 7  # 5: yaw rate PID: P, I, D, IMAX, filter (rad/s)
A_VXY = 12  # 4: horizontal velocity PID: P, I, IMAX (m/s^2), error filter (rad/s)
A_POSZ_P = 16
A_VELZ_P = 17
A_ACCZ = 18  # 4: P, I, IMAX (per mille throttle, cm/s^2 error), error filter (rad/s)
A_ANGLE_MAX = 22  # rad
A_ACCEL_Z_MAX = 23  # m/s^2
A_CLIMB_MAX = 24  # m/s
A_PWM = 25  # 3: min, neutral, max (us)
A_PWM_PER_UNIT = 28  # us per unit motor output
A_TAB_PWM0 = 29  # us of the table's first entry
A_TAB_STEP = 30  # us between entries
A_TAB_N = 31  # entries
A_FACTORS = 32  # 48: per motor roll, pitch, yaw, throttle, forward, lateral
A_TABLE = A_FACTORS + 48  # N_TABLE: thrust (N) on the pulse-width grid
N_TABLE = 201
N_A = A_TABLE + N_TABLE

# --- state ``z``
Z_INIT = 0  # 1 once initialised (targets taken from the first measurement)
Z_IV = 1  # 2: horizontal velocity I terms (m/s^2)
Z_EV = 3  # 2: filtered horizontal velocity errors (m/s)
Z_DEPTH_T = 5  # depth target (m)
Z_VZ_T = 6  # shaped descent-rate target (m/s, down)
Z_ACC_I = 7  # vertical acceleration I term (per mille throttle, down)
Z_ACC_E = 8  # filtered vertical acceleration error (cm/s^2, down)
Z_ACC_MEAS = 9  # heave acceleration of the last step (m/s^2, down): the IMU's
Z_YAW_T = 10  # heading target (rad)
Z_RATE_I = 11  # 3: rate PID I terms (roll, pitch, yaw)
Z_RATE_E = 14  # 3: filtered rate errors (rad/s) of the last step
Z_OUT = 17  # 8: motor outputs in [-1, 1] of the last step
Z_INPUTS = 25  # 6: mixer inputs roll, pitch, yaw, throttle (up), forward, lateral
N_Z = 31


@njit(cache=True)
def thrust_of_pwm(pwm: float, a: np.ndarray) -> float:
    """Bollard thrust (N) of one thruster at pulse width ``pwm`` (us): the table,
    linear between its grid points, flat beyond its ends."""
    n = int(a[A_TAB_N])
    f = (pwm - a[A_TAB_PWM0]) / a[A_TAB_STEP]
    if f <= 0.0:
        return a[A_TABLE]
    if f >= n - 1:
        return a[A_TABLE + n - 1]
    i = int(f)
    w = f - i
    return (1.0 - w) * a[A_TABLE + i] + w * a[A_TABLE + i + 1]


@njit(cache=True)
def mix_vectored_6dof(inputs: np.ndarray, a: np.ndarray, out: np.ndarray) -> None:
    """AP_Motors6DOF's vectored 6-DOF mixer: motor outputs (8,) in [-1, 1] from the
    inputs roll, pitch, yaw, throttle (up), forward, lateral. Roll, pitch and
    throttle mix on the factors' first group (the vertical thrusters), yaw, forward
    and lateral on the second (the horizontal ones); each group is scaled down
    together, keeping its direction, when a motor of it would exceed 1."""
    rpt = np.empty(8)
    yfl = np.empty(8)
    rpt_max = 1.0
    yfl_max = 1.0
    for i in range(8):
        f = A_FACTORS + 6 * i
        rpt[i] = inputs[0] * a[f] + inputs[1] * a[f + 1] + inputs[3] * a[f + 3]
        yfl[i] = inputs[2] * a[f + 2] + inputs[4] * a[f + 4] + inputs[5] * a[f + 5]
        if abs(rpt[i]) > rpt_max:
            rpt_max = abs(rpt[i])
        if abs(yfl[i]) > yfl_max:
            yfl_max = abs(yfl[i])
    for i in range(8):
        v = rpt[i] / rpt_max + yfl[i] / yfl_max
        out[i] = 1.0 if v > 1.0 else (-1.0 if v < -1.0 else v)


@njit(cache=True)
def _wrap(x: float) -> float:
    return (x + math.pi) % (2.0 * math.pi) - math.pi


@njit(cache=True)
def ardusub_step(
    h: float,
    vref: np.ndarray,
    gyro: np.ndarray,
    att: np.ndarray,
    depth: float,
    vhat: np.ndarray,
    a: np.ndarray,
    z: np.ndarray,
    thrust: np.ndarray,
) -> None:
    """One step of ``h`` s of ArduSub's GUIDED velocity control: the thrust (N) each
    of the 8 thrusters is driven to (``thrust``, the ESC's steady bollard thrust of
    its pulse width), from the velocity reference ``vref`` [u v w p q r] (p, q
    ignored, as the driver does not send them), the gyro rates (rad/s), the
    attitude (rad; non-finite: no attitude control this step), the depth (m) and
    the velocity estimate ``vhat`` (m/s, body; the DVL's). State in ``z``."""
    have_att = math.isfinite(att[0]) and math.isfinite(att[1]) and math.isfinite(att[2])
    if z[Z_INIT] < 0.5:
        z[Z_DEPTH_T] = depth
        z[Z_VZ_T] = 0.0
        z[Z_YAW_T] = att[2] if have_att else 0.0
        z[Z_INIT] = 1.0
    inputs = z[Z_INPUTS : Z_INPUTS + 6]
    # ---- horizontal: PSC_VELXY PI on the filtered error -> acceleration -> lean angle
    # -> forward / lateral (translate_pos_control_rp: angle / ANGLE_MAX)
    aw = 1.0 - math.exp(-a[A_VXY + 3] * h)
    amax = a[A_ANGLE_MAX]
    for i in range(2):
        e = z[Z_EV + i] + aw * (vref[i] - vhat[i] - z[Z_EV + i])
        z[Z_EV + i] = e
        integ = z[Z_IV + i] + a[A_VXY + 1] * e * h
        imax = a[A_VXY + 2]
        integ = imax if integ > imax else (-imax if integ < -imax else integ)
        z[Z_IV + i] = integ
        angle = math.atan((a[A_VXY] * e + integ) / GRAVITY)
        angle = amax if angle > amax else (-amax if angle < -amax else angle)
        inputs[4 + i] = angle / amax
    # ---- vertical: the descent rate moves the depth target (shaped by PILOT_ACCEL_Z),
    # PSC_POSZ_P -> rate, PSC_VELZ_P -> acceleration, PSC_ACCZ PI on the measured one
    cmax = a[A_CLIMB_MAX]
    want = vref[2]
    want = cmax if want > cmax else (-cmax if want < -cmax else want)
    dv = want - z[Z_VZ_T]
    step = a[A_ACCEL_Z_MAX] * h
    dv = step if dv > step else (-step if dv < -step else dv)
    acc_ff = dv / h
    z[Z_VZ_T] += dv
    # the target stops where the thrusters are already at their limit pushing that way
    # (AC_PosControl stops the target when the motors saturate)
    thr_last = inputs[3]  # up positive
    if (z[Z_VZ_T] > 0.0 and thr_last <= -1.0) or (z[Z_VZ_T] < 0.0 and thr_last >= 1.0):
        z[Z_VZ_T] = 0.0
        acc_ff = 0.0
    z[Z_DEPTH_T] += z[Z_VZ_T] * h
    rate_t = z[Z_VZ_T] + a[A_POSZ_P] * (z[Z_DEPTH_T] - depth)
    acc_t = acc_ff + a[A_VELZ_P] * (rate_t - vhat[2])
    ae = 1.0 - math.exp(-a[A_ACCZ + 3] * h)
    err_cm = z[Z_ACC_E] + ae * (100.0 * (acc_t - z[Z_ACC_MEAS]) - z[Z_ACC_E])
    z[Z_ACC_E] = err_cm
    ai = z[Z_ACC_I] + a[A_ACCZ + 1] * err_cm * h
    imax = a[A_ACCZ + 2]
    ai = imax if ai > imax else (-imax if ai < -imax else ai)
    z[Z_ACC_I] = ai
    thr_down = 0.001 * (a[A_ACCZ] * err_cm + ai)  # throttle above hover (0.5), down positive
    thr = -2.0 * thr_down  # get_throttle_bidirectional: up positive, in [-1, 1]
    inputs[3] = 1.0 if thr > 1.0 else (-1.0 if thr < -1.0 else thr)
    # ---- attitude: roll, pitch held level (no pilot input), heading target moved by the
    # yaw rate (AUTO_YAW_RATE); angle P -> rate targets (yaw rate fed forward) -> rate PIDs
    z[Z_YAW_T] = _wrap(z[Z_YAW_T] + vref[5] * h)
    if have_att:
        targets = (
            a[A_ANG_P] * (0.0 - att[0]),
            a[A_ANG_P] * (0.0 - att[1]),
            vref[5] + a[A_ANG_Y_P] * _wrap(z[Z_YAW_T] - att[2]),
        )
        for k in range(3):
            base = A_Y if k == 2 else A_RP
            kp, ki, kd, imax, wf = a[base], a[base + 1], a[base + 2], a[base + 3], a[base + 4]
            af = 1.0 - math.exp(-wf * h)
            prev = z[Z_RATE_E + k]
            e = prev + af * (targets[k] - gyro[k] - prev)
            z[Z_RATE_E + k] = e
            integ = z[Z_RATE_I + k] + ki * e * h
            integ = imax if integ > imax else (-imax if integ < -imax else integ)
            z[Z_RATE_I + k] = integ
            inputs[k] = kp * e + integ + kd * (e - prev) / h
    else:
        inputs[0] = inputs[1] = inputs[2] = 0.0
    # ---- mixer, ESCs: pulse width 1500 + 400 u within MOT_PWM_MIN/MAX, bollard thrust
    out = z[Z_OUT : Z_OUT + 8]
    mix_vectored_6dof(inputs, a, out)
    for i in range(8):
        pwm = a[A_PWM + 1] + a[A_PWM_PER_UNIT] * out[i]
        pwm = a[A_PWM] if pwm < a[A_PWM] else (a[A_PWM + 2] if pwm > a[A_PWM + 2] else pwm)
        thrust[i] = thrust_of_pwm(pwm, a)
