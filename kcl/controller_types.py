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
    def of(
        cls, q: np.ndarray, eta: np.ndarray, v: np.ndarray | None, t: float, altitude: float | None = None
    ) -> MeasuredState:
        """``MeasuredState(q, eta, v, t, altitude)``, the same object, built without the
        frozen dataclass's ``__init__`` (which sets each field through
        ``object.__setattr__``): the runtime builds one every 10 ms step."""
        obj = _new(cls)
        obj.__dict__.update(q=q, eta=eta, v=v, t=t, altitude=altitude)
        return obj


_new = object.__new__
_ND = np.ndarray
_F8 = np.dtype(float)


def _kernel_ready(x: np.ndarray) -> bool:
    """Whether ``x`` is an array the compiled kernels take as it is: a float64
    ndarray, C-contiguous and writable."""
    if x.__class__ is not _ND or x.dtype is not _F8:
        return False
    flags = x.flags
    return flags.writeable and flags.c_contiguous


def kernel_ready(meas: MeasuredState) -> MeasuredState:
    """``meas`` itself when its arrays are what the compiled kernels take (float64,
    C-contiguous, writable ndarrays), else the same measurement with such copies.

    Numba types a read-only or strided array apart from a writable contiguous
    one, and the KCL's kernels are compiled for the latter only (never mid-run),
    so another kind makes each compiled call fail its type match (Numba builds
    an error message) and the step run the step by step path (``maris log
    replay`` ran ~4x slower so). Readings are often read-only on purpose, to
    catch code that would change them in place (the readings a replay serves,
    the ArduSub driver's shared arrays); the controller's steps copy such
    arrays here, once per step. Values, shapes and non-finite entries are left
    as they are (the steps check them).
    """
    q, eta, v = meas.q, meas.eta, meas.v
    if _kernel_ready(q) and _kernel_ready(eta) and (v is None or _kernel_ready(v)):
        return meas
    return MeasuredState.of(
        np.array(q, dtype=float),
        np.array(eta, dtype=float),
        None if v is None else np.array(v, dtype=float),
        meas.t,
        meas.altitude,
    )
