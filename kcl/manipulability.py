"""Arm manipulability and its analytic gradient (MARIS eq. 14-18), compiled.

``mu(q) = sqrt(det(J J^T))`` of the arm-only geometric Jacobian ``J`` (6 x l,
columns ``[z_j x r_j; z_j]``, any common axes: mu is rotation invariant); for
l < 6 the 6 x 6 product is singular and ``J^T J`` is used instead.

Gradient without finite differences: ``d mu / d q_i = mu <K, dJ/dq_i>`` with
``K = (J J^T)^-1 J``, where ``dJ_j/dq_i = [z_i x Jlin_j; z_i x z_j]`` when joint i
is above joint j in the chain (a rigid rotation of column j) and
``[z_j x Jlin_i; 0]`` when i is j or below it (the frame point moves by
``Jlin_i``). The inner products are regrouped as triple products. Which joints
are above which comes from the model (:meth:`kcl.model.UvmsModel.hessian_masks`).
"""

from __future__ import annotations

import math

import numpy as np

from kcl.jit import njit


@njit
def manipulability_gradient(Ja: np.ndarray, above: np.ndarray, below: np.ndarray, grad: np.ndarray) -> float:
    """mu of the arm-only Jacobian ``Ja`` (6 x l); ``grad`` (l,) gets dmu/dq (zero
    when mu < 1e-12). ``above[i, j]`` = 1 where joint i is strictly above joint j
    (both moving the frame), ``below[i, j]`` = 1 where i is j or below it."""
    l = Ja.shape[1]
    M = Ja @ Ja.T if l >= 6 else Ja.T @ Ja
    mu = math.sqrt(max(np.linalg.det(M), 0.0))
    for i in range(l):
        grad[i] = 0.0
    if mu < 1e-12:
        return mu
    K = np.linalg.solve(M, Ja) if l >= 6 else Ja @ np.linalg.inv(M)
    for i in range(l):
        g = 0.0
        for j in range(l):
            if above[i, j] != 0.0:  # z_i . (Jlin_j x K_j + z_j x Ka_j)
                c0 = (Ja[1, j] * K[2, j] - Ja[2, j] * K[1, j]) + (Ja[4, j] * K[5, j] - Ja[5, j] * K[4, j])
                c1 = (Ja[2, j] * K[0, j] - Ja[0, j] * K[2, j]) + (Ja[5, j] * K[3, j] - Ja[3, j] * K[5, j])
                c2 = (Ja[0, j] * K[1, j] - Ja[1, j] * K[0, j]) + (Ja[3, j] * K[4, j] - Ja[4, j] * K[3, j])
                g += above[i, j] * (Ja[3, i] * c0 + Ja[4, i] * c1 + Ja[5, i] * c2)
            if below[i, j] != 0.0:  # Jlin_i . (K_j x z_j)
                c0 = K[1, j] * Ja[5, j] - K[2, j] * Ja[4, j]
                c1 = K[2, j] * Ja[3, j] - K[0, j] * Ja[5, j]
                c2 = K[0, j] * Ja[4, j] - K[1, j] * Ja[3, j]
                g += below[i, j] * (Ja[0, i] * c0 + Ja[1, i] * c1 + Ja[2, i] * c2)
        grad[i] = mu * g
    return mu
