"""Public data types of the controller: its options and one measurement.

:class:`ControllerConfig` configures a :class:`kcl.controller.UvmsController`;
:class:`MeasuredState` is what the runtime hands it every cycle (SI units,
radians; pose in world NED, velocity in the vehicle frame).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

#: Default |v| bounds of the vehicle reference: u, v, w (m/s), p, q, r (rad/s).
DEFAULT_VEHICLE_LIMIT = (0.5, 0.5, 0.3, 0.2, 0.2, 0.3)


@dataclass
class ControllerConfig:
    """Options of :class:`UvmsController`.

    vehicle_rate_hz / arm_rate_hz: rates the runtime calls ``vehicle_step`` /
    ``arm_step`` at (informative for the caller; the filter uses real sample times).
    filter_cutoff_rad_s: cutoff of the measured-velocity low-pass (MARIS: 50).
    compensation: TPIK 2 uses the measured vehicle velocity (True) or the
    commanded one (False, for comparison).
    actuated_dofs: which of ``[u v w p q r]`` the thrusters control.
    vehicle_velocity_limit: (6,) |v| bounds, m/s and rad/s.
    joint_velocity_limit: (l,) |qdot| bounds, rad/s; None = the URDF's.
    lam / threshold: default regularization; None = the actions file's.
    eta: weight of the (I - Q) term of the iCAT pseudo-inverse.
    """

    vehicle_rate_hz: float = 10.0
    arm_rate_hz: float = 100.0
    filter_cutoff_rad_s: float = 50.0
    compensation: bool = True
    actuated_dofs: tuple[bool, ...] = (True,) * 6
    vehicle_velocity_limit: tuple[float, ...] = DEFAULT_VEHICLE_LIMIT
    joint_velocity_limit: tuple[float, ...] | None = None
    lam: float | None = None
    threshold: float | None = None
    eta: float = 1.0


@dataclass(frozen=True)
class MeasuredState:
    """What the controller measures at time ``t`` (s).

    q: (l,) joint positions, rad. eta: (6,) vehicle pose ``[x y z roll pitch yaw]``,
    world NED. v: (6,) measured body velocity (vehicle frame) or None (no DVL).
    altitude: m above the bottom, or None if unknown.
    """

    q: np.ndarray
    eta: np.ndarray
    v: np.ndarray | None
    t: float
    altitude: float | None = None

    @classmethod
    def of(cls, q: np.ndarray, eta: np.ndarray, v: np.ndarray | None, t: float,
           altitude: float | None = None) -> "MeasuredState":
        """``MeasuredState(q, eta, v, t, altitude)``, the same object, built without the
        frozen dataclass's ``__init__`` (which sets each field through
        ``object.__setattr__``): the runtime builds one every 10 ms step."""
        obj = _new(cls)
        obj.__dict__.update(q=q, eta=eta, v=v, t=t, altitude=altitude)
        return obj


_new = object.__new__

