"""Arm manipulability (inequality ``mu >= mu_min``, MARIS eq. 14-18).

x = mu(q) = sqrt(det(J_a J_a^T)) of the arm-only Jacobian of ``frame`` (the
tool by default; mixed m / rad units). Activation: decreasing bell over
``[mu_min, mu_min + width]``, reference ``gain (mu_min + width - mu)``.
Jacobian ``[dmu/dq  0_{1x6}]`` (analytic gradient, kcl.model), computed only
while the task is active (``mu < mu_min + width``; zero otherwise, where the
activation is zero too).
"""

from __future__ import annotations

import math

import numpy as np

from kcl.small_linalg import gram_sqrt_det
from kcl.tasks.base import GAIN, MAX_RATE, Param, Task
from kcl.tasks.jit import decreasing_bell, njit, saturate_into


@njit
def manipulability_rows(p, frames, P, Jw, q, eta, wRv, env, x, J, a, xdot, err):
    """Row kernel (kcl.tasks.jit). p = [gain, max_rate, mu_min, width,
    above (l x l, row-major), at_or_below (l x l)] (masks of
    ``UvmsModel._hessian_masks``); frames = [frame]. Same algebra as
    :meth:`kcl.model.Kinematics.manipulability`."""
    l = q.shape[0]
    f = frames[0]
    Ja = np.ascontiguousarray(Jw[f, :, :l])  # arm-only Jacobian, world axes (mu is rotation invariant)
    xbar = p[2] + p[3]
    mu = gram_sqrt_det(Ja)
    x[0] = mu
    if mu >= xbar:  # inactive: the gradient (the costly part) is not needed
        return 0
    if not np.isfinite(Ja).all():  # refused by the solver (NaN activation), never raised here
        x[0] = a[0] = math.nan
        return 0
    M = Ja @ Ja.T if l >= 6 else Ja.T @ Ja
    mu = math.sqrt(max(np.linalg.det(M), 0.0))
    x[0] = mu
    if mu >= 1e-12:
        K = np.linalg.solve(M, Ja) if l >= 6 else Ja @ np.linalg.inv(M)
        # column j of Ja is [Jlin_j; z_j]; see Kinematics.manipulability
        for i in range(l):
            g = 0.0
            for j in range(l):
                w_above = p[4 + i * l + j]
                w_below = p[4 + l * l + i * l + j]
                if w_above != 0.0:  # z_i . (Jlin_j x K_j + z_j x Ka_j)
                    c0 = (Ja[1, j] * K[2, j] - Ja[2, j] * K[1, j]) + (Ja[4, j] * K[5, j] - Ja[5, j] * K[4, j])
                    c1 = (Ja[2, j] * K[0, j] - Ja[0, j] * K[2, j]) + (Ja[5, j] * K[3, j] - Ja[3, j] * K[5, j])
                    c2 = (Ja[0, j] * K[1, j] - Ja[1, j] * K[0, j]) + (Ja[3, j] * K[4, j] - Ja[4, j] * K[3, j])
                    g += w_above * (Ja[3, i] * c0 + Ja[4, i] * c1 + Ja[5, i] * c2)
                if w_below != 0.0:  # Jlin_i . (K_j x z_j)
                    c0 = K[1, j] * Ja[5, j] - K[2, j] * Ja[4, j]
                    c1 = K[2, j] * Ja[3, j] - K[0, j] * Ja[5, j]
                    c2 = K[0, j] * Ja[4, j] - K[1, j] * Ja[3, j]
                    g += w_below * (Ja[0, i] * c0 + Ja[1, i] * c1 + Ja[2, i] * c2)
            J[0, i] = mu * g
    a[0] = decreasing_bell(mu, p[2], xbar)
    err[0] = xbar - mu if a[0] > 0.0 else 0.0
    saturate_into(xdot, err, p[0], p[1])
    return 0


class ArmManipulability(Task):
    TYPE = "arm_manipulability"
    KIND = "inequality"
    USES_VEHICLE = False
    PARAMS = {
        "gain": GAIN,
        "max_rate": MAX_RATE,
        "mu_min": Param(0.01, "positive", "minimum manipulability"),
        "width": Param(0.01, "positive", "transition width of the activation"),
        "frame": Param("tool", "frame", "frame (role or URDF name) whose manipulability is kept up"),
    }
    ROW_KERNEL = staticmethod(manipulability_rows)
    KERNEL_ID = 9

    def kernel_params(self) -> list[float]:
        p = self.params
        above, at_or_below = self.model._hessian_masks(p["frame"])
        return [
            float(p["gain"]),
            float(p["max_rate"]),
            float(p["mu_min"]),
            float(p["width"]),
            *above.ravel().tolist(),
            *at_or_below.ravel().tolist(),
        ]

    def kernel_frames(self) -> list[str]:
        return [self.params["frame"]]

    def dim(self) -> int:
        return 1
