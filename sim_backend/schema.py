"""Every scenario parameter of the simulator: name, kind, default, bounds.

A scenario file sets any subset of these (dotted names are ``section.key`` in the
YAML: ``dvl: {noise_std_mps: 0.02}``); the rest keep the defaults below. The
defaults describe an R2-class vehicle (MARIS: 1.3 x 0.9 x 1.0 m, ~400 kg, 8
thrusters) in the MARIS test pool; the comments in
``sim_backend/scenarios/pool_clear.yaml`` explain where each number comes from.

Each parameter is a :class:`sim_backend.param.Param`. Kinds:

* ``float``: a number within [lo, hi].
* ``range``: a number, or ``{min: a, max: b}``, drawn uniformly from the run's
  seed when the simulator is built (a fixed number stays fixed).
* ``int``, ``bool``, ``str``.
* ``vec``: ``n`` numbers within [lo, hi]; ``bools``: ``n`` booleans.
* ``intervals``: a list of ``[t_start, t_end]`` pairs (s, simulated time).
* ``turbidity``: one of :data:`TURBIDITY_LEVELS`, or ``{choice: [...]}`` drawn from the seed.
* ``per_turbidity``: a mapping with one number per turbidity level.
* ``floats_or_null``: ``null`` or a list of numbers (length checked later).
"""

from __future__ import annotations

from .param import INF, Param
from .schema_ardusub import ARDUSUB_PARAMS
from .schema_dynamics import DYNAMICS_PARAMS
from .schema_errors import ERROR_PARAM_ARGS
from .schema_render import RENDER_PARAM_ARGS

__all__ = ["INF", "PARAMS", "PARAMS_BY_KEY", "SECTIONS", "TURBIDITY_LEVELS", "Param"]

TURBIDITY_LEVELS: tuple[str, ...] = ("clear", "slightly_turbid", "very_turbid")

P = Param
PARAMS: tuple[Param, ...] = (
    P("description", "str", ""),
    # --- simulation
    P("sim.step_s", "float", 0.01, 1e-4, 0.1, unit="s"),
    # --- world
    P("pool.size_m", "vec", (25.0, 12.0, 4.0), 0.5, 1000.0, 3, "m (north, east, depth)"),
    P("current.velocity_mps", "vec", (0.0, 0.0, 0.0), -2.0, 2.0, 3, "m/s NED"),
    P("current.rejection", "float", 0.7, 0.0, 1.0, unit="fraction rejected by the vehicle's velocity loop"),
    P("pipe.length_m", "float", 1.0, 0.1, 10.0, unit="m"),
    P("pipe.radius_m", "float", 0.05, 0.0025, 0.1, unit="m"),
    P("pipe.float_height_m", "range", 0.05, 0.0, 2.0, unit="m above the floor"),
    P("pipe.x_m", "range", 12.5, -INF, INF, unit="m north"),
    P("pipe.y_m", "range", 6.0, -INF, INF, unit="m east"),
    P("pipe.yaw_rad", "range", 0.0, -10.0, 10.0, unit="rad"),
    P("pipe.grasp_offset_m", "range", 0.0, -5.0, 5.0, unit="m along the axis from the centre"),
    P("pipe.wet_weight_n", "float", 2.0, -100.0, 100.0, unit="N, weight minus buoyancy (negative floats up)"),
    # --- vehicle
    P("vehicle.start_x_m", "range", 8.5, -INF, INF, unit="m"),
    P("vehicle.start_y_m", "range", 6.0, -INF, INF, unit="m"),
    P("vehicle.start_z_m", "range", 2.8, -INF, INF, unit="m (depth)"),
    P("vehicle.start_yaw_rad", "range", 0.0, -10.0, 10.0, unit="rad"),
    P("vehicle.actuated", "bools", (True,) * 6, n=6),
    P("vehicle.time_constant_s", "vec", (0.8, 0.9, 0.6, 0.4, 0.4, 0.6), 0.0, 30.0, 6, "s"),
    P("vehicle.max_velocity", "vec", (0.5, 0.3, 0.3, 0.2, 0.2, 0.4), 0.0, 5.0, 6, "m/s, rad/s"),
    P("vehicle.dead_band", "vec", (0.01, 0.01, 0.01, 0.005, 0.005, 0.01), 0.0, 1.0, 6, "m/s, rad/s"),
    P("vehicle.low_speed_gain", "vec", (0.6, 0.6, 0.7, 0.7, 0.7, 0.6), 0.0, 2.0, 6, "steady-state gain near zero"),
    P("vehicle.low_speed_scale", "vec", (0.05, 0.05, 0.05, 0.03, 0.03, 0.05), 1e-6, 10.0, 6, "m/s, rad/s"),
    P("vehicle.disturbance_std", "vec", (0.01, 0.01, 0.005, 0.003, 0.003, 0.005), 0.0, 1.0, 6, "m/s, rad/s"),
    P("vehicle.disturbance_time_s", "float", 3.0, 0.01, 1000.0, unit="s"),
    P("vehicle.restoring_period_s", "float", 3.0, 0.1, 100.0, unit="s"),
    P("vehicle.restoring_damping", "float", 0.5, 0.0, 5.0, unit="damping ratio"),
    # --- arm
    P("arm.time_constant_s", "float", 0.01, 0.0, 5.0, unit="s, drives' velocity-loop lag"),
    P("arm.start_q", "floats_or_null", None, unit="rad"),
    P("arm.idle_current_a", "float", 0.3, 0.0, 50.0, unit="A"),
    P("arm.current_per_rad_s", "float", 1.5, 0.0, 100.0, unit="A per rad/s"),
    P("arm.current_noise_a", "float", 0.02, 0.0, 10.0, unit="A"),
    P("arm.encoder_noise_rad", "float", 1e-4, 0.0, 0.1, unit="rad"),
    # --- gripper and grasp
    P("gripper.speed_rad_s", "float", 0.6, 1e-3, 20.0, unit="rad/s"),
    P("gripper.closed_rad", "float", 1.6, 0.1, 4.0, unit="rad"),
    P("gripper.idle_current_a", "float", 0.05, 0.0, 20.0, unit="A"),
    P("gripper.moving_current_a", "float", 0.35, 0.0, 20.0, unit="A"),
    P("gripper.current_rise_time_s", "float", 0.15, 1e-3, 10.0, unit="s"),
    P("gripper.current_noise_a", "float", 0.02, 0.0, 5.0, unit="A"),
    P(
        "grasp.across_tolerance_m",
        "float",
        0.05,
        0.0,
        1.0,
        unit="m, pipe axis to tool origin, across the axis and the approach",
    ),
    P(
        "grasp.approach_tolerance_m",
        "float",
        0.04,
        0.0,
        1.0,
        unit="m, pipe axis to tool origin, along the approach (tool z)",
    ),
    P(
        "grasp.end_clearance_m",
        "float",
        0.06,
        0.0,
        5.0,
        unit="m, least distance from the tool origin to a pipe end, along the axis",
    ),
    P("grasp.axis_tolerance_rad", "float", 0.35, 0.0, 1.6, unit="rad between tool x and the pipe axis"),
    P("grasp.capture_radius_m", "float", 0.10, 0.0, 1.0, unit="m"),
    # --- wrist force/torque sensor
    P("ft.present", "bool", True),
    P("ft.force_noise_n", "float", 0.3, 0.0, 100.0, unit="N"),
    P("ft.torque_noise_nm", "float", 0.03, 0.0, 10.0, unit="N m"),
    # --- navigation sensors
    P("dvl.present", "bool", True),
    P("dvl.rate_hz", "float", 5.0, 0.1, 100.0, unit="Hz"),
    P("dvl.noise_std_mps", "float", 0.01, 0.0, 1.0, unit="m/s"),
    P("dvl.dropout_probability", "float", 0.02, 0.0, 1.0, unit="per ping"),
    P("dvl.dropouts", "intervals", ()),
    P("dvl.min_altitude_m", "float", 0.5, 0.0, 100.0, unit="m (at the transducers)"),
    P("dvl.max_altitude_m", "float", 80.0, 0.0, 10000.0, unit="m"),
    P("ahrs.rate_hz", "float", 100.0, 1.0, 1000.0, unit="Hz"),
    P("ahrs.attitude_noise_std_rad", "float", 0.003, 0.0, 1.0, unit="rad"),
    P("ahrs.yaw_noise_std_rad", "float", 0.01, 0.0, 1.0, unit="rad"),
    P("ahrs.rate_noise_std_rad_s", "float", 0.0037, 0.0, 1.0, unit="rad/s, white gyro noise per sample"),
    P("depth.noise_std_m", "float", 0.005, 0.0, 1.0, unit="m"),
    P("navigation.position_drift_m_per_sqrt_s", "float", 0.005, 0.0, 1.0, unit="m/sqrt(s)"),
    # --- vision
    P("vision.rate_hz", "float", 10.0, 0.1, 100.0, unit="Hz"),
    P("vision.latency_s", "float", 0.15, 0.0, 5.0, unit="s"),
    P("vision.fov_h_rad", "float", 1.0, 0.01, 3.1, unit="rad (full angle)"),
    P("vision.fov_v_rad", "float", 0.78, 0.01, 3.1, unit="rad (full angle)"),
    P("vision.min_range_m", "float", 0.3, 0.0, 100.0, unit="m"),
    P("vision.max_range_m", "float", 6.0, 0.0, 100.0, unit="m"),
    P("vision.turbidity", "turbidity", "clear"),
    P(
        "vision.detection_probability",
        "per_turbidity",
        {"clear": 0.95, "slightly_turbid": 0.5, "very_turbid": 0.03},
        0.0,
        1.0,
    ),
    P("vision.visibility_m", "per_turbidity", {"clear": 8.0, "slightly_turbid": 3.5, "very_turbid": 1.2}, 0.0, 100.0),
    P(
        "vision.position_noise_m",
        "float",
        0.005,
        0.0,
        1.0,
        unit="m at 1 m range (x range laterally, x range^2 in depth)",
    ),
    P("vision.angle_noise_rad", "float", 0.02, 0.0, 1.0, unit="rad"),
    P("vision.occlusion_factor", "float", 0.7, 0.0, 1.0, unit="detection probability lost when the arm hides the pipe"),
    P("vision.occlusion_radius_m", "float", 0.07, 0.0, 1.0, unit="m (arm link radius)"),
    P("vision.dropouts", "intervals", ()),
    # --- operator (a gamepad's recorded event stream, evemu text: sim_backend.devices.SimGamepad)
    P("operator.gamepad_recording", "str", "", unit="evemu file, relative to the scenario file; empty: untouched"),
    P("operator.gamepad_start_s", "float", -1.0, -1.0, INF, unit="s when the recording starts; < 0: at the first read"),
    P("operator.gamepad_unplug_s", "float", INF, 0.0, INF, unit="s when the gamepad disappears (never: inf)"),
) + tuple(Param(*args) for args in RENDER_PARAM_ARGS)

PARAMS = PARAMS + DYNAMICS_PARAMS + tuple(Param(*args) for args in ERROR_PARAM_ARGS) + ARDUSUB_PARAMS

PARAMS_BY_KEY: dict[str, Param] = {p.key: p for p in PARAMS}
SECTIONS: tuple[str, ...] = tuple(dict.fromkeys(p.key.split(".")[0] for p in PARAMS if "." in p.key))
