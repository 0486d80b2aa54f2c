"""Hull parameters of the full vehicle model, true and nominal (pure functions).

The *true* values drive the simulated physics; the *nominal* values are what
the vehicle's own controller (DCL) believes. They differ because a vehicle's
added mass and damping are known only to identification accuracy: each true
coefficient is the nominal one times ``1 + U(-e, e)`` with
``e = vehicle.model_uncertainty``, drawn from the run's seed (stream
``"hydro"``), and each thruster's gain is ``1 + U(-s, s)`` with
``s = thrusters.gain_spread`` (stream ``"thrusters"``).

Rigid body (Fossen's notation, reference point = centre of gravity, vehicle
frame FRD): mass ``m`` and the principal inertia ``vehicle.inertia_kgm2``, or
without it that of a uniform box of ``vehicle.size_m``
(``I_xx = m (w^2 + h^2) / 12`` ...). Restoring: the centre of buoyancy lies
``vehicle.metacentric_height_m`` (BG) above the centre of gravity, giving roll and
pitch moments ``-BG B sin(angle)``; ``vehicle.net_buoyancy_n`` is buoyancy minus
weight.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .rng import child_rng

#: Gravity (m/s^2) and sea-water density are not parameters: a pool is fresh water.
GRAVITY = 9.81
WATER_DENSITY = 1000.0


def box_inertia(mass: float, size: tuple[float, float, float]) -> np.ndarray:
    """Principal inertia (3,) kg m^2 of a uniform box of ``size`` (length x, width y, height z)."""
    lx, ly, lz = size
    return mass / 12.0 * np.array([ly * ly + lz * lz, lx * lx + lz * lz, lx * lx + ly * ly])


@dataclass(frozen=True)
class HullParams:
    """Numbers of one run. Vectors are per DOF ``[u v w p q r]``."""

    rigid: np.ndarray  # (6,) m, m, m, Ixx, Iyy, Izz (true)
    added: np.ndarray  # (6,) true added mass
    lin: np.ndarray  # (6,) true linear damping
    quad: np.ndarray  # (6,) true quadratic damping
    added_nominal: np.ndarray
    lin_nominal: np.ndarray
    quad_nominal: np.ndarray
    bg_buoyancy: float  # BG * B (N m): restoring moment per unit sin(angle)
    net_buoyancy: float  # N, true buoyancy minus weight
    thruster_gain: np.ndarray  # (8,) true thrust / nominal thrust

    @property
    def nominal_inertia(self) -> np.ndarray:
        """(6,) what the DCL uses for ``M``: rigid body + nominal added mass."""
        return self.rigid + self.added_nominal


def hull_params(p: dict, seed: int) -> HullParams:
    """Build the run's hull from scenario values ``p`` and draw its uncertainties."""
    m = float(p["vehicle.mass_kg"])
    inertia = p.get("vehicle.inertia_kgm2")  # measured or identified; else the uniform box
    box = box_inertia(m, tuple(p["vehicle.size_m"])) if inertia is None else np.asarray(inertia, dtype=float)
    rigid = np.concatenate([np.full(3, m), box])
    added = np.asarray(p["vehicle.added_mass"], dtype=float)
    lin = np.asarray(p["vehicle.linear_damping"], dtype=float)
    quad = np.asarray(p["vehicle.quadratic_damping"], dtype=float)
    e = float(p["vehicle.model_uncertainty"])
    rng = child_rng(seed, "hydro")
    f = 1.0 + e * rng.uniform(-1.0, 1.0, size=(3, 6))
    s = float(p["thrusters.gain_spread"])
    gains = 1.0 + s * child_rng(seed, "thrusters").uniform(-1.0, 1.0, size=8)
    buoyancy = m * GRAVITY + float(p["vehicle.net_buoyancy_n"])
    return HullParams(
        rigid=rigid,
        added=added * f[0],
        lin=lin * f[1],
        quad=quad * f[2],
        added_nominal=added.copy(),
        lin_nominal=lin.copy(),
        quad_nominal=quad.copy(),
        bg_buoyancy=float(p["vehicle.metacentric_height_m"]) * buoyancy,
        net_buoyancy=float(p["vehicle.net_buoyancy_n"]),
        thruster_gain=gains,
    )


def roll_period(hull: HullParams, axis: int = 3) -> float:
    """Natural period (s) of the free roll (axis 3) or pitch (4) oscillation."""
    if hull.bg_buoyancy <= 0.0:
        return math.inf
    return 2.0 * math.pi * math.sqrt((hull.rigid[axis] + hull.added[axis]) / hull.bg_buoyancy)
