"""Frequency response of the MARIS Fig. 17 loop on this simulator (pure, linear).

The loop: the gyro measures the vehicle's angular rate ``w``; TPIK 2 (arm rate,
through the optional first-order filter) moves the joints so that the tool
stays still, ``qdot_ref = -J_arm^+ J_veh w_meas``; the drives follow with their
velocity-loop lag; the links' momentum ``h = M_bq qdot`` pushes the hull back;
the hull (rigid body + added mass, damping, its own DCL closed on the gyro
through the DCL's filter and the thrusters' lag) turns. Per rotation axis,
linearized at a posture, this is a scalar loop with the open-loop transfer
function::

    L(s) = g * M s / (M s + d + C(s)) * D(s) * F(s) * exp(-s T)

* ``g``: the static momentum ratio of :func:`sim_backend.coupling.compensation_loop_gain`
  (the arm's compensating momentum per unit vehicle rate, over the hull's
  inertia; positive: the arm's reaction adds to the vehicle's rate);
* ``M``: the hull's inertia about the axis (rigid, added, the locked arm's), ``d``
  its linear damping; ``C(s) = (Kp + Ki / s) W(s) Th(s)`` the DCL (its PI gains
  from ``dcl.bandwidth_rad_s`` as in :mod:`sim_backend.full_vehicle`, ``W`` the
  DCL's gyro filter ``dcl.gyro_filter_rad_s``, ``Th`` the thrusters' lag);
* ``D(s) = 1 / (1 + arm.time_constant_s s)``: the drives' velocity loops;
* ``F(s) = 1 / (1 + s / w_f)``: the KCL's feedback filter (``None``: no filter);
* ``T``: the sampling delay of the arm loop (one period plus half a period of
  zero-order hold: the gyro sample of one step acts on the next).

With the feedback positive (``g > 0``), an oscillation can sustain itself only
where ``|L| >= 1`` with the phase near zero; ``|L| < 1`` at every frequency
means the loop only amplifies what the gyro noise puts in, by ``1 / |1 - L|``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .coupling import compensation_loop_gain_params
from .hydrodynamics import box_inertia
from .scenario import load_scenario

AXES = {"roll": 3, "pitch": 4, "yaw": 5}


@dataclass(frozen=True)
class LoopResponse:
    """``L(j 2 pi f)`` for one axis: frequencies (Hz), complex values, the static gain ``g``."""

    axis: str
    g: float
    freqs_hz: np.ndarray
    L: np.ndarray

    @property
    def peak(self) -> tuple[float, float, float]:
        """``(|L| max, at frequency Hz, phase there in deg)``."""
        i = int(np.argmax(np.abs(self.L)))
        return float(abs(self.L[i])), float(self.freqs_hz[i]), float(np.degrees(np.angle(self.L[i])))

    def amplification(self) -> np.ndarray:
        """``|1 / (1 - L)|``: how much the loop amplifies noise entering at each frequency."""
        return np.abs(1.0 / (1.0 - self.L))


def loop_response(
    scenario: str = "pool_apr2016",
    posture: str = "grasp_ready",
    *,
    filter_cutoff_rad_s: float | None = 50.0,
    arm_rate_hz: float = 100.0,
    freqs_hz: np.ndarray | None = None,
    overrides: dict | None = None,
) -> dict[str, LoopResponse]:
    """The loop's response per axis (nominal values of ``scenario``, no random draws)."""

    p = load_scenario(scenario, overrides).values
    f = np.logspace(-1, math.log10(0.5 * arm_rate_hz), 300) if freqs_hz is None else np.asarray(freqs_hz, dtype=float)
    s = 2j * np.pi * f
    g_by_axis, inertia = compensation_loop_gain_params(p, posture)
    m = float(p["vehicle.mass_kg"])
    rigid = box_inertia(m, tuple(p["vehicle.size_m"]))
    added = np.asarray(p["vehicle.added_mass"], dtype=float)[3:]
    lin = np.asarray(p["vehicle.linear_damping"], dtype=float)[3:]
    w_dcl = np.asarray(p["dcl.bandwidth_rad_s"], dtype=float)[3:]
    w_gyro = float(p["dcl.gyro_filter_rad_s"])
    tau_thr = float(p["thrusters.time_constant_s"])
    tau_arm = float(p["arm.time_constant_s"])
    T = 1.5 / arm_rate_hz
    D = 1.0 / (1.0 + tau_arm * s)
    F = 1.0 if filter_cutoff_rad_s is None else 1.0 / (1.0 + s / float(filter_cutoff_rad_s))
    delay = np.exp(-s * T)
    out = {}
    for name, axis in AXES.items():
        k = axis - 3
        M = float(inertia[axis])
        m_dcl = float(rigid[k] + added[k])  # what the DCL's gains are designed on
        C = (2.0 * m_dcl * w_dcl[k] + m_dcl * w_dcl[k] ** 2 / s) / (1.0 + s / w_gyro) / (1.0 + tau_thr * s)
        hull = M * s / (M * s + lin[k] + C)
        out[name] = LoopResponse(name, float(g_by_axis[name]), f, g_by_axis[name] * hull * D * F * delay)
    return out


def loop_table(scenario: str = "pool_apr2016", arm_rate_hz: float = 100.0) -> list[dict]:
    """Rows (axis, g, peak |L| and where, unfiltered and with the 50 rad/s filter, and the
    noise amplification at 10 and 20 Hz), for docs and the results page."""
    rows = []
    unf = loop_response(scenario, filter_cutoff_rad_s=None, arm_rate_hz=arm_rate_hz)
    fil = loop_response(scenario, filter_cutoff_rad_s=50.0, arm_rate_hz=arm_rate_hz)
    for name in AXES:
        pu, fu, phu = unf[name].peak
        pf, ff, _ = fil[name].peak
        amp_u = unf[name].amplification()
        amp_f = fil[name].amplification()
        at = lambda arr, hz: float(np.interp(hz, unf[name].freqs_hz, arr))  # noqa: E731, B023 - used in this iteration
        rows.append(
            {
                "axis": name,
                "g": unf[name].g,
                "peak_unfiltered": pu,
                "peak_hz_unfiltered": fu,
                "phase_deg_unfiltered": phu,
                "peak_filtered": pf,
                "peak_hz_filtered": ff,
                "amp10_unfiltered": at(amp_u, 10.0),
                "amp10_filtered": at(amp_f, 10.0),
                "amp20_unfiltered": at(amp_u, 20.0),
                "amp20_filtered": at(amp_f, 20.0),
            }
        )
    return rows
