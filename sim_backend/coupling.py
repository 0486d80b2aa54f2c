"""Arm-vehicle dynamic coupling (floating-base dynamics).

The arm's drives are stiff velocity loops behind high-ratio gears, so the
joint motion ``q, qdot, qddot`` is taken as given (prescribed by the drive
model, :mod:`sim_backend.arm_sim`); the floating base then obeys the first six
rows of the whole system's equation of motion::

    M_bb(q) nu_dot + M_bq(q) qddot + h_b(q, nu, qdot) = tau_ext

``M_bb`` is the vehicle's rigid-body inertia plus the arm's (locked) inertia
seen at the vehicle frame, ``M_bq qddot`` the reaction of accelerating links and
``h_b`` the Coriolis and centrifugal terms, arm included. With Pinocchio's
free-flyer root these are ``crba(q)[:6, :6]`` and the base rows of
``rnea(q, [nu; qdot], [0; qddot])`` (the base velocity of Pinocchio's free
flyer is the body velocity ``[v; w]`` in the vehicle frame, as ours).

Model: the URDF's links and inertias (``kcl/data/r2_uma.urdf``), with

* the root body replaced by the run's hull (``vehicle.mass_kg`` and
  ``vehicle.inertia_kgm2``, or the box inertia of ``vehicle.size_m``; the hull's
  added mass is added by the caller);
* each moving link's mass and inertia scaled by ``1 + arm.link_added_mass_ratio``
  (water moved with the link; a slender cylinder's transverse added mass equals
  its displaced mass);
* no gravity: links are taken as neutrally buoyant in water (the arm's weight
  is trimmed by its buoyancy), so the arm exerts no static moment; link drag is
  neglected (a few newtons at the arm's 0.3 m/s).

The simulator's step computes the terms with :mod:`sim_backend.coupling_kernel`
(the same recursions, compiled, on this Pinocchio model's numbers: ``cpw``);
:meth:`ArmCoupling.terms` and :meth:`ArmCoupling.base_inertia` call Pinocchio
itself (tests, diagnostics, :func:`compensation_loop_gain`).
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np
import pinocchio as pin

from kcl.actions import load_actions
from kcl.model import UvmsModel

from .coupling_kernel import N_G, N_W, pack_model
from .hydrodynamics import box_inertia
from .scenario import load_scenario


class ArmCoupling:
    """Coupling terms for one run. ``terms(q, qdot, qddot, nu)`` -> ``(M_bb, b)``."""

    def __init__(
        self,
        urdf_path: str,
        mass: float,
        size: tuple[float, float, float],
        link_added_ratio: float,
        inertia: tuple[float, float, float] | None = None,
    ):
        """``inertia``: the hull's principal inertia (kg m^2); None: the uniform box of ``size``."""
        model = pin.buildModelFromUrdf(str(urdf_path), pin.JointModelFreeFlyer())
        model.gravity.linear[:] = 0.0
        hull_inertia = box_inertia(float(mass), size) if inertia is None else np.asarray(inertia, dtype=float)
        model.inertias[1] = pin.Inertia(float(mass), np.zeros(3), np.diag(hull_inertia))
        f = 1.0 + float(link_added_ratio)
        for j in range(2, model.njoints):
            I = model.inertias[j]
            model.inertias[j] = pin.Inertia(I.mass * f, I.lever.copy(), I.inertia * f)
        self.model = model
        self.data = model.createData()
        self.n_joints = model.nv - 6
        self._q = pin.neutral(model)
        self._v = np.zeros(model.nv)
        self._a = np.zeros(model.nv)
        self._q_crba: bool | None = None
        self._pin_Mbb = np.zeros((6, 6))
        #: the model's numbers and scratch for the compiled terms (:mod:`sim_backend.coupling_kernel`)
        geo = pack_model(model)
        self.cpw = np.zeros((len(geo), N_G + N_W))  # one array for the compiled step: model, then scratch
        self.cpw[:, :N_G] = geo
        self.geo, self.work = self.cpw[:, :N_G], self.cpw[:, N_G:]

    def base_inertia(self, q: np.ndarray, moved: bool = True) -> np.ndarray:
        """``M_bb`` (6, 6): vehicle + locked arm at joint positions ``q`` (rad). Only
        its upper triangle is filled (it is symmetric; Pinocchio's ``crba`` writes
        the upper part). ``moved=False`` reuses the last one (joints still)."""
        if moved or self._q_crba is None:
            self._q[7:] = q
            self._pin_Mbb = pin.crba(self.model, self.data, self._q)[:6, :6]
            self._q_crba = True
        return self._pin_Mbb

    def terms(
        self, q: np.ndarray, qdot: np.ndarray, qddot: np.ndarray, nu: np.ndarray, moved: bool = True
    ) -> tuple[np.ndarray, np.ndarray]:
        """``(M_bb (6, 6) upper triangle, b (6,))`` with ``b = M_bq qddot + h_b`` (N,
        N m, vehicle frame); ``moved``: whether ``q`` changed since the last call."""
        Mbb = self.base_inertia(q, moved)
        self._v[:6] = nu
        self._v[6:] = qdot
        self._a[6:] = qddot
        tau = pin.rnea(self.model, self.data, self._q, self._v, self._a)
        return Mbb, tau[:6].copy()

    def arm_momentum(self, q: np.ndarray, qdot: np.ndarray) -> np.ndarray:
        """Momentum (6,) the joint motion alone gives the system, at the vehicle frame
        (``M_bq qdot``: linear N s, angular N m s), for tests and diagnostics."""
        self._q[7:] = q
        M = pin.crba(self.model, self.data, self._q)
        return M[:6, 6:] @ qdot


def compensation_loop_gain(scenario: str = "pool_clear", posture: str = "grasp_ready") -> dict[str, float]:
    """How strongly the compensating arm feeds a vehicle rotation back (dimensionless).

    With the arm at ``posture`` (``kcl/data/actions.yaml``), the KCL's compensation
    moves the joints so the tool stays still while the vehicle turns at 1 rad/s
    about roll, pitch or yaw; the links' reaction then turns the vehicle by the
    returned fraction of that rate (free-floating momentum balance, added masses
    of the scenario included). Below 1 the loop cannot sustain an oscillation on
    its own: it only amplifies what the sensor noise puts in, by about 1 / (1 - gain).
    Its frequency response: :mod:`sim_backend.loop_analysis`.
    """

    return compensation_loop_gain_params(load_scenario(scenario).values, posture)[0]


def compensation_loop_gain_params(
    p: Mapping[str, Any], posture: str = "grasp_ready"
) -> tuple[dict[str, float], np.ndarray]:
    """:func:`compensation_loop_gain` for scenario values ``p``; also returns the
    diagonal (6,) of the hull's inertia with the locked arm and added masses."""

    model = UvmsModel.load()
    q = np.array(load_actions(None, model).postures[posture], dtype=float)
    cp = ArmCoupling(
        model.urdf_path, float(p["vehicle.mass_kg"]), tuple(p["vehicle.size_m"]), float(p["arm.link_added_mass_ratio"])
    )
    M = cp.base_inertia(q)
    M = np.triu(M) + np.triu(M, 1).T + np.diag(np.asarray(p["vehicle.added_mass"], dtype=float))
    J = model.kinematics(q, np.zeros(6)).jacobian_world("tool")
    l = model.n_joints
    out = {}
    for axis, name in ((3, "roll"), (4, "pitch"), (5, "yaw")):
        v = np.zeros(6)
        v[axis] = 1.0
        qdot = -np.linalg.pinv(J[:, :l]) @ (J[:, l:] @ v)
        out[name] = float(-cp.arm_momentum(q, qdot)[axis] / M[axis, axis])
    return out, np.diag(M).copy()
