"""The ArduSub autopilot of a BlueROV2 below the KCL (``vehicle.autopilot: ardusub_guided``).

What is modelled is what our driver makes the autopilot do.
:mod:`hal.drivers.ardusub` (``command: setpoint``) keeps the vehicle armed in
GUIDED and sends, at 10 Hz, SET_POSITION_TARGET_LOCAL_NED with the velocities
``u, v, w`` in MAV_FRAME_BODY_OFFSET_NED (rotated by the heading only; ``w``
along NED down) and, from ArduSub 4.1, the yaw rate ``r``; ``p`` and ``q`` are
never sent. ArduSub (``ArduSub/mode_guided.cpp``, ``guided_vel_control_run``;
AC_PosControl, AC_AttitudeControl_Sub, ``AP_Motors6DOF.cpp``) then, every loop:

1. **Horizontal**: the position controller's velocity loop with the position
   stabilisation stopped: acceleration target = PSC_VELXY P and I on the
   filtered velocity error (no D by default); the acceleration becomes a lean
   angle ``atan(a / g)``, which ArduSub does not fly but turns into the
   forward and lateral thrust inputs ``angle / ANGLE_MAX``
   (``translate_pos_control_rp``).
2. **Vertical**: the climb rate moves a depth target (shaped by PILOT_ACCEL_Z);
   PSC_POSZ_P makes a rate target, PSC_VELZ_P an acceleration target, and the
   PSC_ACCZ PID on the measured acceleration the throttle, 0.5 being neutral.
3. **Attitude**: roll and pitch targets zero (no pilot input), the heading
   target moved by the yaw rate (AUTO_YAW_RATE); the angle P gains give rate
   targets and the rate PIDs (ATC_RAT_*) the roll, pitch and yaw inputs.
4. **Mixer** (FRAME_CONFIG vectored_6dof, ``output_armed_stabilizing_vectored_6dof``):
   each motor's output is the sum of roll, pitch, throttle times its factors
   (vertical thrusters) and yaw, forward, lateral times its factors (horizontal
   ones); a group whose largest output exceeds 1 is divided by it (direction
   kept, no priority between the axes), the sum clipped to [-1, 1];
   ``calc_thrust_to_pwm``: pulse width 1500 + 400 u within MOT_PWM_MIN/MAX.
5. **Thrusters**: the T200's bollard thrust at that pulse width, from Blue
   Robotics' published table (its dead band included), interpolated by a
   monotone cubic (PCHIP) through the table's points; a first-order lag on the
   propeller speed (thrust ~ speed squared), as the MARIS thrusters.

Simplifications (each a stated departure from the firmware):

* the controllers run at the simulator's step (10 ms) instead of ArduSub's 400 Hz loop;
* the horizontal velocity is the DVL's body ``u, v`` (ArduSub's EKF rotates it by
  the full attitude into NE and the output back by the heading: the same for the
  small roll and pitch this controller holds);
* the attitude errors are Euler-angle differences with body rates (ArduSub works
  on quaternions and shapes its targets; the same for small errors);
* the measured vertical acceleration is the hull's true heave acceleration of
  the last step (no accelerometer noise, no vibration);
* no battery current limit (MOT_BAT_*), no forward/vertical decoupling (that is
  the ``vectored`` frame's, not ``vectored_6dof``'s), no jerk limits.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from . import ardusub_kernel as ak


def thrust_table(pwm_us: tuple[float, ...], thrust_n: tuple[float, ...], lo: float, hi: float) -> np.ndarray:
    """Thrust (N) on ``ak.N_TABLE`` pulse widths evenly from ``lo`` to ``hi`` (us):
    the monotone cubic through the bollard points (flat beyond them)."""
    from scipy.interpolate import PchipInterpolator

    grid = np.linspace(lo, hi, ak.N_TABLE)
    x = np.asarray(pwm_us, dtype=float)
    y = np.asarray(thrust_n, dtype=float)
    return PchipInterpolator(x, y, extrapolate=False)(np.clip(grid, x[0], x[-1]))


def explicit_geometry(positions: tuple[float, ...], directions: tuple[float, ...]) -> np.ndarray:
    """Thrust configuration matrix B (6, 8): the body wrench ``[X Y Z K M N]`` of a
    unit positive output of each thruster, from their positions (m, vehicle frame,
    about the centre of gravity) and force directions (normalized here)."""
    r = np.asarray(positions, dtype=float).reshape(8, 3)
    d = np.asarray(directions, dtype=float).reshape(8, 3)
    d = d / np.linalg.norm(d, axis=1, keepdims=True)
    B = np.zeros((6, 8))
    B[:3] = d.T
    B[3:] = np.cross(r, d).T
    return B


def pack_constants(p: dict[str, Any]) -> np.ndarray:
    """The constants ``a`` (``ak.A_*`` layout) of scenario values ``p``."""
    a = np.zeros(ak.N_A)
    two_pi = 2.0 * math.pi
    a[ak.A_ANG_P], a[ak.A_ANG_Y_P] = p["ardusub.angle_p"]
    for base, key in ((ak.A_RP, "ardusub.rate_rp_pid"), (ak.A_Y, "ardusub.rate_yaw_pid")):
        kp, ki, kd, imax, hz = p[key]
        a[base : base + 5] = (kp, ki, kd, imax, two_pi * hz)
    kp, ki, imax, hz = p["ardusub.vel_xy_pid"]
    a[ak.A_VXY : ak.A_VXY + 4] = (kp, ki, imax, two_pi * hz)
    a[ak.A_POSZ_P] = p["ardusub.pos_z_p"]
    a[ak.A_VELZ_P] = p["ardusub.vel_z_p"]
    kp, ki, imax, hz = p["ardusub.accel_z_pid"]
    a[ak.A_ACCZ : ak.A_ACCZ + 4] = (kp, ki, imax, two_pi * hz)
    a[ak.A_ANGLE_MAX] = math.radians(p["ardusub.angle_max_deg"])
    a[ak.A_ACCEL_Z_MAX] = p["ardusub.pilot_accel_z_mps2"]
    a[ak.A_CLIMB_MAX] = p["ardusub.max_climb_mps"]
    lo, mid, hi = p["ardusub.pwm_us"]
    a[ak.A_PWM : ak.A_PWM + 3] = (lo, mid, hi)
    a[ak.A_PWM_PER_UNIT] = 400.0  # calc_thrust_to_pwm: 1500 + 400 u
    a[ak.A_TAB_PWM0] = lo
    a[ak.A_TAB_STEP] = (hi - lo) / (ak.N_TABLE - 1)
    a[ak.A_TAB_N] = ak.N_TABLE
    a[ak.A_FACTORS : ak.A_FACTORS + 48] = p["ardusub.motor_factors"]
    a[ak.A_TABLE : ak.A_TABLE + ak.N_TABLE] = thrust_table(
        p["thrusters.table_pwm_us"], p["thrusters.table_thrust_n"], lo, hi
    )
    return a


def thrust_limits(a: np.ndarray) -> tuple[float, float]:
    """(largest forward thrust, largest reverse thrust) (N, both positive) of the table."""
    t = a[ak.A_TABLE : ak.A_TABLE + ak.N_TABLE]
    return float(t.max()), float(-t.min())
