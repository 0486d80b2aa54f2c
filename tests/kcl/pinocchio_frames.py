"""The tests' reference for frame poses and Jacobians: Pinocchio's own
``computeJointJacobians`` on the model's free-flyer twin, columns reordered from
Pinocchio's velocity order (base first) to ours (``[qdot; v]``, joints first)."""

from __future__ import annotations

import numpy as np
import pinocchio as pin

from kcl.model import UvmsModel
from kcl.rotations import rpy_to_matrix


def pinocchio_frame(model: UvmsModel, q: np.ndarray, eta: np.ndarray, frame: str) -> tuple[np.ndarray, np.ndarray]:
    """World pose (4x4) and world Jacobian (6 x n, ``LOCAL_WORLD_ALIGNED``) of ``frame``
    (role or URDF name) at joints ``q`` (rad) and vehicle pose ``eta`` (world NED, m, rad)."""
    ff = model.ff_model
    data = ff.createData()
    quat = pin.Quaternion(rpy_to_matrix(eta[3], eta[4], eta[5]))
    qff = np.r_[eta[:3], quat.coeffs(), q]
    pin.computeJointJacobians(ff, data, qff)
    fid = model.ff_frame_id(frame)
    pose = pin.updateFramePlacement(ff, data, fid).homogeneous.copy()
    J = pin.getFrameJacobian(ff, data, fid, pin.ReferenceFrame.LOCAL_WORLD_ALIGNED)
    l = model.n_joints
    return pose, J[:, np.r_[6 : 6 + l, 0:6]]
