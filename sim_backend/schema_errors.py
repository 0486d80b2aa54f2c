"""Scenario parameters of the simulator's systematic sensor errors and mounts.

Kept apart from :mod:`sim_backend.schema`, which appends them to its table as
:class:`~sim_backend.param.Param` (key, kind, default, lo, hi, n, unit):

* ``vision.calib_*`` / ``vision.mount_*``: the stereo calibration and camera
  mount errors drawn once per run (:mod:`sim_backend.vision_calibration`);
* ``dvl.mount_z_m``: how far below the vehicle's reference point the DVL's
  transducers are (bottom lock is judged at the transducers, the reported
  altitude is the reference point's, as a navigation filter reports it).

Where each default comes from: ``sim_backend/scenarios/pool_clear.yaml``.
"""

from __future__ import annotations

ERROR_PARAM_ARGS: tuple[tuple, ...] = (
    ("vision.calib_focal_rel_std", "float", 0.003, 0.0, 0.2, 0, "relative focal length error per camera (std)"),
    (
        "vision.calib_principal_px_std",
        "float",
        0.5,
        0.0,
        50.0,
        0,
        "px principal point error per coordinate and camera (std)",
    ),
    (
        "vision.calib_stereo_rot_std_rad",
        "float",
        0.00087,
        0.0,
        0.2,
        0,
        "rad error of the right camera's rotation per axis (std)",
    ),
    (
        "vision.calib_stereo_trans_std_m",
        "float",
        0.0005,
        0.0,
        0.1,
        0,
        "m error of the right camera's position per axis (std)",
    ),
    ("vision.mount_rot_std_rad", "float", 0.004, 0.0, 0.2, 0, "rad error of the camera-to-arm rotation per axis (std)"),
    ("vision.mount_trans_std_m", "float", 0.003, 0.0, 0.2, 0, "m error of the camera-to-arm position per axis (std)"),
    ("dvl.mount_z_m", "float", 0.5, -10.0, 10.0, 0, "m, DVL transducers below the vehicle's reference point"),
)
