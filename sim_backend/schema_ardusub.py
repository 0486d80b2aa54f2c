"""Scenario parameters of a BlueROV2-class platform: the ArduSub autopilot below
the KCL, explicit thruster geometry and a tabulated thrust curve, an explicit
hull inertia, the Ping echosounder, the Reach jaw, and which URDF and actions
file the scenario's rig is.

Appended to ``sim_backend.schema.PARAMS`` like :mod:`sim_backend.schema_dynamics`.
Where every number of the shipped BlueROV2 scenarios comes from is written next
to it in ``sim_backend/scenarios/bluerov2_pool.yaml``. Defaults keep the R2 model
of :mod:`sim_backend.schema_dynamics` unchanged (MARIS DCL, quadratic thrust,
box inertia, no Ping, the three-motor hand).

``vehicle.autopilot``:

* ``maris_dcl``: the MARIS DCL (per-DOF PI + feedforward, torque-first allocation);
* ``ardusub_guided``: what ArduSub does in GUIDED with the velocity setpoints of
  ``hal.drivers.ardusub`` (``command: setpoint``): :mod:`sim_backend.ardusub`.
"""

from __future__ import annotations

from typing import Any

from maris_common.yamlsrc import suggest

from .param import Param

P = Param

#: Names accepted by ``vehicle.autopilot``.
AUTOPILOTS: tuple[str, ...] = ("maris_dcl", "ardusub_guided")
#: Names accepted by ``thrusters.curve``.
THRUST_CURVES: tuple[str, ...] = ("quadratic", "table")
#: Names accepted by ``gripper.model``.
GRIPPER_MODELS: tuple[str, ...] = ("hand", "jaw")

ARDUSUB_PARAMS: tuple[Param, ...] = (
    # --- which rig the scenario simulates (file names in kcl/data/ or paths from the scenario file)
    P("platform.model", "str", "", unit="URDF of the rig ('' = the run's model decides)"),
    P("platform.actions", "str", "", unit="actions YAML of the rig ('' = the run's choice)"),
    # --- hull and autopilot
    P("vehicle.autopilot", "str", "maris_dcl", unit="maris_dcl | ardusub_guided"),
    P(
        "vehicle.inertia_kgm2",
        "floats_or_null",
        None,
        unit="kg m^2: Ixx, Iyy, Izz (null: uniform box of vehicle.size_m)",
    ),
    # --- thrusters: explicit layout and a tabulated thrust curve
    P("thrusters.curve", "str", "quadratic", unit="quadratic | table"),
    P("thrusters.table_pwm_us", "floats_or_null", None, unit="us, ESC pulse widths of the thrust table (increasing)"),
    P("thrusters.table_thrust_n", "floats_or_null", None, unit="N, bollard thrust at those pulse widths"),
    P("thrusters.positions_m", "floats_or_null", None, unit="m: x, y, z of the 8 thrusters (FRD), motor order"),
    P("thrusters.directions", "floats_or_null", None, unit="force direction of each thruster for a positive output"),
    # --- ArduSub (defaults: ArduSub's own, see bluerov2_pool.yaml)
    P("ardusub.motor_factors", "floats_or_null", None, unit="roll, pitch, yaw, throttle, forward, lateral per motor"),
    P("ardusub.pwm_us", "vec", (1100.0, 1500.0, 1900.0), 500.0, 2500.0, 3, "us: MOT_PWM_MIN, neutral, MOT_PWM_MAX"),
    P("ardusub.angle_p", "vec", (6.0, 6.0), 0.0, 100.0, 2, "1/s: ATC_ANG_RLL_P (= PIT), ATC_ANG_YAW_P"),
    P(
        "ardusub.rate_rp_pid",
        "vec",
        (0.135, 0.09, 0.0036, 0.444, 30.0),
        0.0,
        1000.0,
        5,
        "ATC_RAT_RLL (= PIT): P (1/(rad/s)), I, D, IMAX, filter Hz",
    ),
    P(
        "ardusub.rate_yaw_pid",
        "vec",
        (0.18, 0.018, 0.0, 0.222, 5.0),
        0.0,
        1000.0,
        5,
        "ATC_RAT_YAW: P (1/(rad/s)), I, D, IMAX, filter Hz",
    ),
    P(
        "ardusub.vel_xy_pid",
        "vec",
        (1.0, 0.5, 10.0, 5.0),
        0.0,
        1000.0,
        4,
        "PSC_VELXY: P (1/s), I (1/s^2), IMAX (m/s^2), error filter Hz",
    ),
    P("ardusub.pos_z_p", "float", 3.0, 0.0, 100.0, unit="1/s, PSC_POSZ_P"),
    P("ardusub.vel_z_p", "float", 8.0, 0.0, 100.0, unit="1/s, PSC_VELZ_P"),
    P(
        "ardusub.accel_z_pid",
        "vec",
        (0.5, 0.1, 100.0, 20.0),
        0.0,
        10000.0,
        4,
        "PSC_ACCZ: P, I (per mille throttle per cm/s^2), IMAX (per mille), error filter Hz",
    ),
    P("ardusub.angle_max_deg", "float", 45.0, 1.0, 89.0, unit="deg, ANGLE_MAX: full forward/lateral output"),
    P("ardusub.pilot_accel_z_mps2", "float", 1.0, 0.01, 100.0, unit="m/s^2, PILOT_ACCEL_Z: shaping of the climb rate"),
    P("ardusub.max_climb_mps", "float", 0.5, 0.01, 10.0, unit="m/s, PILOT_SPEED_UP / _DN"),
    # --- Ping echosounder (altitude)
    P("ping.present", "bool", False),
    P("ping.rate_hz", "float", 10.0, 0.1, 100.0, unit="Hz, readings asked for"),
    P("ping.noise_std_m", "float", 0.01, 0.0, 1.0, unit="m"),
    P("ping.beam_rad", "float", 0.436, 0.01, 3.0, unit="rad, full beam width"),
    P("ping.min_range_m", "float", 0.3, 0.0, 100.0, unit="m"),
    P("ping.max_range_m", "float", 100.0, 0.1, 1000.0, unit="m"),
    P("ping.mount_z_m", "float", 0.1, -5.0, 5.0, unit="m, transducer below the reference point"),
    P("ping.low_confidence_probability", "float", 0.02, 0.0, 1.0, unit="per reading"),
    P("ping.filter_time_s", "float", 0.2, 0.0, 10.0, unit="s, the sonar's own tracking filter"),
    P("ping.timeout_s", "float", 1.0, 0.01, 100.0, unit="s, older readings are no altitude"),
    # --- the gripper: the MARIS hand or a Reach jaw
    P("gripper.model", "str", "hand", unit="hand | jaw"),
    P("jaw.speed_mm_s", "float", 3.0, 0.01, 100.0, unit="mm/s of the jaw's rod"),
    P("jaw.max_opening_mm", "float", 15.0, 0.1, 200.0, unit="mm, rod travel"),
    P("jaw.finger_rad_per_mm", "float", 0.051, 0.0001, 10.0, unit="rad of each finger per mm of rod"),
    P("jaw.finger_max_rad", "float", 0.5, 0.01, 3.0, unit="rad, finger opening cap"),
    P("jaw.hinge_y_m", "float", 0.0155, 0.0, 0.5, unit="m, finger hinges off the tool's x-z plane"),
    P("jaw.tcp_beyond_hinge_m", "float", 0.0331, 0.0, 1.0, unit="m, tool origin beyond the hinges along z"),
    P("jaw.preshape_mm", "vec", (12.0, 8.0), 0.0, 200.0, 2, "mm: openings of the preshapes parallel, small_pipe"),
)


def ardusub_cross_checks(values: dict[str, Any]) -> list[tuple[str, str]]:
    """Consistency of the parameters above: ``(key, message)`` pairs."""
    out: list[tuple[str, str]] = []
    for key, names in (
        ("vehicle.autopilot", AUTOPILOTS),
        ("thrusters.curve", THRUST_CURVES),
        ("gripper.model", GRIPPER_MODELS),
    ):
        if values[key] not in names:
            out.append(
                (key, f"unknown value {values[key]!r}{suggest(str(values[key]), names)}; known: {', '.join(names)}")
            )
    if values["thrusters.curve"] == "table":
        pwm, thrust = values["thrusters.table_pwm_us"], values["thrusters.table_thrust_n"]
        if pwm is None or thrust is None:
            out.append(("thrusters.curve", "a `table` curve needs thrusters.table_pwm_us and thrusters.table_thrust_n"))
        elif len(pwm) != len(thrust) or len(pwm) < 3:
            out.append(("thrusters.table_thrust_n", "needs one thrust per pulse width of table_pwm_us (3 or more)"))
        elif any(b <= a for a, b in zip(pwm, pwm[1:])):
            out.append(("thrusters.table_pwm_us", "pulse widths must increase"))
        elif any(b < a for a, b in zip(thrust, thrust[1:])) or not (min(thrust) < 0.0 < max(thrust)):
            out.append(
                ("thrusters.table_thrust_n", "thrust must not decrease with the pulse width and must change sign")
            )
    for key, n in (("thrusters.positions_m", 24), ("thrusters.directions", 24), ("ardusub.motor_factors", 48)):
        v = values[key]
        if v is not None and len(v) != n:
            out.append((key, f"expected {n} numbers (8 thrusters), got {len(v)}"))
    if (values["thrusters.positions_m"] is None) != (values["thrusters.directions"] is None):
        out.append(("thrusters.directions", "give both thrusters.positions_m and thrusters.directions, or neither"))
    inertia = values["vehicle.inertia_kgm2"]
    if inertia is not None and (len(inertia) != 3 or min(inertia) <= 0.0):
        out.append(("vehicle.inertia_kgm2", "expected 3 positive principal inertias (kg m^2)"))
    if values["vehicle.autopilot"] == "ardusub_guided":
        if values["ardusub.motor_factors"] is None or values["thrusters.positions_m"] is None:
            out.append(
                (
                    "vehicle.autopilot",
                    "ardusub_guided needs the frame: ardusub.motor_factors, thrusters.positions_m, thrusters.directions",
                )
            )
        if values["thrusters.curve"] != "table":
            out.append(("thrusters.curve", "ardusub_guided drives the ESCs by pulse width: use `table`"))
        if not values["dvl.present"]:
            out.append(
                (
                    "dvl.present",
                    "ArduSub refuses GUIDED without a position estimate (mode_guided.cpp init): "
                    "a BlueROV2 without a DVL flies ALT_HOLD with manual_control, which this model does not simulate",
                )
            )
        lo, mid, hi = values["ardusub.pwm_us"]
        if not lo < mid < hi:
            out.append(("ardusub.pwm_us", "expected MOT_PWM_MIN < neutral < MOT_PWM_MAX"))
    if values["ping.min_range_m"] >= values["ping.max_range_m"]:
        out.append(("ping.min_range_m", "must be smaller than ping.max_range_m"))
    return out
