"""kcl.kin_frames: the compiled frame poses and world Jacobians equal
Pinocchio's (computeJointJacobians on the free-flyer twin) to ~1e-15 over
random states; models the chain does not cover are refused by name."""

from __future__ import annotations

import numpy as np
import pytest
from pinocchio_frames import pinocchio_frame

from kcl.kin_frames import frames_world
from kcl.model import UvmsModel
from kcl.rotations import rpy_to_matrix


@pytest.fixture(scope="module")
def model() -> UvmsModel:
    return UvmsModel.load()


def test_frames_match_pinocchio(model) -> None:
    roles = tuple(model.frames)
    chain = model.chain(roles)
    rng = np.random.default_rng(3)
    P = np.zeros((len(roles), 4, 4))
    Jw = np.zeros((len(roles), 6, model.n))
    worst = 0.0
    for _ in range(200):
        q = rng.uniform(model.joint_lower, model.joint_upper)
        eta = np.r_[rng.uniform(-20, 20, 3), rng.uniform(-1.2, 1.2, 2), rng.uniform(-np.pi, np.pi)]
        frames_world(q, eta, rpy_to_matrix(*eta[3:]), chain[0], chain[1], P, Jw)
        for i, frame in enumerate(roles):
            pose, J = pinocchio_frame(model, q, eta, frame)
            worst = max(worst, np.abs(P[i] - pose).max(), np.abs(Jw[i] - J).max())
    assert worst < 1e-12


def test_a_model_the_chain_does_not_cover_is_refused() -> None:
    import pinocchio as pin

    from kcl.kin_frames import chain_buffers

    fixed_base = pin.buildModelFromUrdf(str(UvmsModel.load().urdf_path))  # no free-flyer root
    with pytest.raises(ValueError, match="root joint is not a free flyer"):
        chain_buffers(fixed_base, (0,))
