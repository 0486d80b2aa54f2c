"""Scenario parameters of the rendered-vision model (``vision.model: rendered``).

Kept apart from :mod:`sim_backend.schema`, which appends them to its table as
:class:`~sim_backend.param.Param` (key, kind, default, lo, hi, n, unit). The
reasoning behind each default is in ``sim_backend/scenarios/pool_vision.yaml``
and ``docs/vision.md``.
"""

from __future__ import annotations

INF = float("inf")

#: Vision models a scenario may select.
VISION_MODELS: tuple[str, ...] = ("table", "rendered")

RENDER_PARAM_ARGS: tuple[tuple, ...] = (
    (
        "vision.model",
        "str",
        "table",
        -INF,
        INF,
        0,
        "table: detections drawn from the truth; rendered: images + the real detector",
    ),
    (
        "vision.water_visibility_m",
        "per_turbidity",
        {"clear": 20.0, "slightly_turbid": 5.0, "very_turbid": 1.5},
        0.05,
        1000.0,
        0,
        "m, horizontal visibility of a dark target (rendered images)",
    ),
    ("vision.image_width", "int", 646, 16, 8192, 0, "px (the Mako's 1292 x 964 halved)"),
    ("vision.image_height", "int", 482, 16, 8192, 0, "px"),
    ("vision.baseline_m", "float", 0.2, 0.01, 2.0, 0, "m between the two cameras"),
    ("vision.calibration", "str", "", -INF, INF, 0, "stereo calibration file (OpenCV or ROS); empty: the nominal rig"),
    ("vision.daylight", "float", 1.0, 0.0, 100.0, 0, "relative daylight at the surface (0: night)"),
    ("vision.lamp_power", "float", 0.0, 0.0, 100.0, 0, "relative power of the vehicle's lamps"),
    ("vision.caustics", "float", 0.35, 0.0, 1.0, 0, "relative amplitude of the pool caustics"),
    ("vision.hsv_hue", "vec", (22.0, 35.0), 0.0, 179.0, 2, "OpenCV hue range of the detector (0-179)"),
    ("vision.hsv_sat_min", "float", 63.0, 0.0, 255.0, 0, "detector's minimum saturation (0-255)"),
    ("vision.hsv_val_min", "float", 30.0, 0.0, 255.0, 0, "detector's minimum value (0-255)"),
    ("vision.log_frames_hz", "float", 1.0, 0.0, 30.0, 0, "Hz, camera frames written to the run log"),
)
