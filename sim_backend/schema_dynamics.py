"""Scenario parameters of the full vehicle model, the thrusters, the DCL, the
arm-vehicle coupling, the gyro noise spectrum and the diver hold.

Kept apart from :mod:`sim_backend.schema` (which appends them to ``PARAMS``) so
that the physics of one model is declared in one place. Units are SI and
radians; vectors over the six DOFs are ``[u v w p q r]`` (surge, sway, heave
in N or kg, roll, pitch, yaw in N m or kg m^2). Where every number comes from
is written next to it in ``sim_backend/scenarios/pool_clear.yaml``; the
``unit`` strings below are shown in validation errors.

``vehicle.model`` chooses the vehicle model: ``full`` (6-DOF rigid body,
thrusters, DCL, arm coupling: :mod:`sim_backend.full_vehicle`) or
``first_order`` (the fast kinematic lag of :mod:`sim_backend.vehicle_dynamics`,
for quick dry runs; it ignores every parameter of this module except the gyro
spectrum).
"""

from __future__ import annotations

from .param import Param

P = Param

#: Names accepted by ``vehicle.model``.
VEHICLE_MODELS: tuple[str, ...] = ("full", "first_order")

DYNAMICS_PARAMS: tuple[Param, ...] = (
    P("vehicle.model", "str", "full", unit="full | first_order"),
    # --- hull (rigid body + hydrodynamics), true values of the simulated vehicle
    P("vehicle.mass_kg", "float", 420.0, 10.0, 10000.0, unit="kg in air"),
    P("vehicle.size_m", "vec", (1.3, 0.9, 1.0), 0.05, 20.0, 3, "m (length, width, height)"),
    P("vehicle.added_mass", "vec", (170.0, 290.0, 290.0, 30.0, 45.0, 40.0), 0.0, 1e5, 6, "kg, kg m^2"),
    P("vehicle.linear_damping", "vec", (60.0, 80.0, 80.0, 20.0, 25.0, 20.0), 0.0, 1e5, 6, "N s/m, N m s/rad"),
    P(
        "vehicle.quadratic_damping",
        "vec",
        (460.0, 670.0, 600.0, 35.0, 55.0, 56.0),
        0.0,
        1e6,
        6,
        "N s^2/m^2, N m s^2/rad^2",
    ),
    P("vehicle.metacentric_height_m", "float", 0.1, 0.0, 2.0, unit="m, centre of buoyancy above the centre of gravity"),
    P("vehicle.net_buoyancy_n", "float", 20.0, -1000.0, 1000.0, unit="N, buoyancy minus weight (positive floats up)"),
    P(
        "vehicle.model_uncertainty",
        "float",
        0.2,
        0.0,
        0.9,
        unit="fraction: true added mass and damping = DCL model x (1 +- this)",
    ),
    P("vehicle.disturbance_force_std", "vec", (1.5, 1.5, 1.5, 0.3, 0.3, 0.3), 0.0, 1e4, 6, "N, N m"),
    P("vehicle.disturbance_force_time_s", "float", 20.0, 0.01, 1e4, unit="s"),
    # --- thrusters: 4 horizontal (vectored) + 4 vertical
    P("thrusters.max_forward_n", "float", 100.0, 0.1, 1e5, unit="N"),
    P("thrusters.max_reverse_n", "float", 70.0, 0.1, 1e5, unit="N"),
    P("thrusters.dead_zone", "float", 0.08, 0.0, 0.9, unit="fraction of the command with no thrust"),
    P("thrusters.time_constant_s", "float", 0.15, 0.0, 5.0, unit="s, propeller speed lag"),
    P("thrusters.gain_spread", "float", 0.1, 0.0, 0.9, unit="fraction: each thruster's thrust = nominal x (1 +- this)"),
    P(
        "thrusters.horizontal_angle_rad",
        "float",
        0.785398,
        0.05,
        1.52,
        unit="rad between each horizontal thruster and the x axis",
    ),
    P("thrusters.horizontal_position_m", "vec", (0.5, 0.35), 0.01, 10.0, 2, "m (|x|, |y|) of the horizontal thrusters"),
    P("thrusters.vertical_position_m", "vec", (0.45, 0.3), 0.01, 10.0, 2, "m (|x|, |y|) of the vertical thrusters"),
    # --- dynamic control layer (vehicle velocity loops)
    P(
        "dcl.bandwidth_rad_s",
        "vec",
        (1.0, 1.0, 1.0, 2.0, 2.0, 1.5),
        0.01,
        100.0,
        6,
        "rad/s closed-loop bandwidth per DOF",
    ),
    P(
        "dcl.depth_observer_rad_s",
        "float",
        1.0,
        0.0,
        50.0,
        unit="rad/s, heave observer on the depth sensor without DVL (0 = off)",
    ),
    P("dcl.gyro_filter_rad_s", "float", 20.0, 0.1, 1e4, unit="rad/s, first-order filter on the gyro rates of the DCL"),
    # --- arm-vehicle coupling
    P("arm.coupling", "bool", True),
    P("arm.link_added_mass_ratio", "float", 0.7, 0.0, 5.0, unit="added mass of a link / its mass"),
    # --- gyro noise spectrum (AHRS angular rates)
    P("ahrs.gyro_bias_std_rad_s", "float", 8.7e-5, 0.0, 1.0, unit="rad/s, in-run bias (Gauss-Markov std)"),
    P("ahrs.gyro_bias_time_s", "float", 100.0, 0.1, 1e6, unit="s, bias correlation time"),
    P("ahrs.vibration_hz", "float", 20.0, 0.01, 1e4, unit="Hz, thruster-driven vibration line"),
    P("ahrs.vibration_rad_s", "float", 0.02, 0.0, 10.0, unit="rad/s amplitude with every thruster at full speed"),
    # --- a vehicle held over the pipe by divers (MARIS October 2015)
    P("diver.hold", "bool", False),
    P("diver.period_s", "float", 4.0, 0.1, 1000.0, unit="s, natural period of the diver's hold"),
    P("diver.damping_ratio", "float", 0.7, 0.0, 10.0),
)
