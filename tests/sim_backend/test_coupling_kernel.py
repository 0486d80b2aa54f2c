"""The compiled coupling terms (sim_backend.coupling_kernel) against Pinocchio's crba and rnea:
the same M_bb and b to rounding over random configurations, velocities and accelerations."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

from sim_backend.coupling import ArmCoupling
from sim_backend.coupling_kernel import N_W, coupling_step, coupling_terms, pack_model


@pytest.fixture(scope="module", params=["r2_uma", "alpha5"])
def coupling(model, request) -> ArmCoupling:
    """The R2 arm on a box hull, and the Reach Alpha 5 on the BlueROV2 Heavy's identified
    inertia (model set A): the coupling works for both URDFs."""
    if request.param == "alpha5":
        from kcl.model import DATA_DIR

        return ArmCoupling(
            str(DATA_DIR / "bluerov2_heavy_alpha5.urdf"), 13.5, (0.457, 0.575, 0.254), 0.5, (0.26, 0.23, 0.37)
        )
    return ArmCoupling(model.urdf_path, 130.0, (1.3, 0.9, 0.6), 0.7)


def test_terms_match_pinocchio_over_random_states(coupling: ArmCoupling) -> None:
    geo = pack_model(coupling.model)
    n = coupling.n_joints
    work, M, b = np.zeros((n + 1, N_W)), np.zeros((6, 6)), np.zeros(6)
    rng = np.random.default_rng(7)
    for _ in range(300):
        q = rng.uniform(-np.pi, np.pi, n)
        qdot, qddot, nu = rng.normal(0.0, 1.0, n), rng.normal(0.0, 5.0, n), rng.normal(0.0, 0.5, 6)
        M_pin, b_pin = coupling.terms(q, qdot, qddot, nu)
        M_pin = np.triu(M_pin) + np.triu(M_pin, 1).T  # crba fills the upper triangle
        coupling_terms(q, qdot, qddot, nu, True, geo, work, M, b)
        assert np.abs(M - M_pin).max() <= 1e-13 * np.abs(M_pin).max()
        assert np.abs(b - b_pin).max() <= 1e-13 * max(1.0, np.abs(b_pin).max())
        np.testing.assert_array_equal(M, M.T)


def test_step_differentiates_the_joint_velocities_and_keeps_the_inertia_while_still(coupling: ArmCoupling) -> None:
    geo = pack_model(coupling.model)
    n, h = coupling.n_joints, 0.01
    work, M, b = np.zeros((n + 1, N_W)), np.zeros((6, 6)), np.zeros(6)
    q, qdot_prev, qddot, nu = np.linspace(-1.0, 1.0, n), np.zeros(n), np.zeros(n), np.array([0.2, 0, 0, 0, 0, 0.1])
    qdot = np.full(n, 0.3)
    coupling_step(h, q, qdot, qdot_prev, qddot, nu, True, geo, work, M, b)
    np.testing.assert_array_equal(qddot, (qdot - 0.0) * (1.0 / h))
    np.testing.assert_array_equal(qdot_prev, qdot)
    M_pin, b_pin = coupling.terms(q, qdot, qddot, nu)
    np.testing.assert_allclose(b, b_pin, rtol=0, atol=1e-12 * np.abs(b_pin).max())
    # joints still: M_bb is kept (the positions did not change), b still follows nu
    still = np.zeros(n)
    M[:] = -1.0
    coupling_step(h, q, still, qdot_prev, qddot, nu, False, geo, work, M, b)
    assert (M == -1.0).all()
    _, b_pin = coupling.terms(q, still, qddot, nu)
    np.testing.assert_allclose(b, b_pin, rtol=0, atol=1e-12 * np.abs(b_pin).max())


def test_pack_model_refuses_a_branching_tree(coupling: ArmCoupling) -> None:
    model = pin.Model(coupling.model)
    model.parents[3] = 1  # a second branch on the hull
    with pytest.raises(ValueError, match="serial chain"):
        pack_model(model)
