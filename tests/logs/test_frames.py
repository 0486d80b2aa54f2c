"""The 3D view's link transforms (mission.logs.frames.LinkTree) against Pinocchio."""

from __future__ import annotations

import math
from types import SimpleNamespace

import numpy as np
import pinocchio as pin
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from kcl.model import UvmsModel
from mission.logs.frames import LinkTree, Transform, pose_to_transform, rotation_to_quaternion


@pytest.fixture(scope="module")
def tree() -> LinkTree:
    return LinkTree(UvmsModel.load())


def _same(a: list[Transform], b: list[Transform]) -> None:
    assert [(t.parent, t.child) for t in a] == [(t.parent, t.child) for t in b]
    for x, y in zip(a, b):
        assert np.allclose(x.translation, y.translation, rtol=0, atol=1e-12), (x, y)
        qa, qb = np.array(x.rotation), np.array(y.rotation)
        assert abs(np.linalg.norm(qa) - 1.0) < 1e-12
        assert min(np.abs(qa - qb).max(), np.abs(qa + qb).max()) < 1e-12, (x, y)  # q and -q: the same rotation


def test_the_reference_arm_takes_the_plain_float_path(tree):
    assert tree._plan is not None
    moving = [e for e in tree._plan if type(e) is not Transform]
    assert len(moving) == tree.model.pin_model.nq  # one edge per revolute joint


@pytest.mark.slow
@settings(max_examples=200, deadline=None)
@given(st.lists(st.floats(-2 * math.pi, 2 * math.pi), min_size=7, max_size=7))
def test_link_transforms_match_pinocchio(tree, q):
    q = np.array(q)
    _same(tree.transforms(q), tree.transforms_pinocchio(q))


THREE_AXES = """<robot name="wrist">
  <link name="base"/><link name="a"/><link name="b"/><link name="c"/><link name="cam"/>
  <joint name="jx" type="revolute"><parent link="base"/><child link="a"/>
    <origin xyz="0.1 -0.2 0.3" rpy="0.4 -0.5 0.6"/><axis xyz="1 0 0"/><limit lower="-3" upper="3" effort="1" velocity="1"/></joint>
  <joint name="jy" type="revolute"><parent link="a"/><child link="b"/>
    <origin xyz="0 0.25 -0.1" rpy="-1.2 0.1 2.9"/><axis xyz="0 1 0"/><limit lower="-3" upper="3" effort="1" velocity="1"/></joint>
  <joint name="jz" type="revolute"><parent link="b"/><child link="c"/>
    <origin xyz="0.3 0 0" rpy="0 1.4 -0.3"/><axis xyz="0 0 1"/><limit lower="-3" upper="3" effort="1" velocity="1"/></joint>
  <joint name="mount" type="fixed"><parent link="c"/><child link="cam"/>
    <origin xyz="0.05 0.02 0.01" rpy="3.0 -0.2 0.7"/></joint>
</robot>"""


@pytest.fixture(scope="module")
def wrist() -> LinkTree:
    return LinkTree(SimpleNamespace(pin_model=pin.buildModelFromXML(THREE_AXES)))


@settings(max_examples=100, deadline=None)
@given(st.lists(st.floats(-2 * math.pi, 2 * math.pi), min_size=3, max_size=3))
def test_joints_about_each_axis_with_turned_origins_match_pinocchio(wrist, q):
    assert wrist._plan is not None
    q = np.array(q)
    _same(wrist.transforms(q), wrist.transforms_pinocchio(q))


@pytest.mark.parametrize("joint", ["prismatic", "continuous"])
def test_other_joints_fall_back_to_pinocchio(joint):
    urdf = """<robot name="slide">
      <link name="base"/><link name="carriage"/><link name="tip"/>
      <joint name="slide" type="JOINT"><parent link="base"/><child link="carriage"/>
        <origin xyz="0.1 0 0.2" rpy="0 0.3 0"/><axis xyz="1 0 0"/><limit lower="-1" upper="1" effort="1" velocity="1"/></joint>
      <joint name="bend" type="revolute"><parent link="carriage"/><child link="tip"/>
        <origin xyz="0 0.4 0" rpy="0.2 0 0"/><axis xyz="0 0 1"/><limit lower="-3" upper="3" effort="1" velocity="1"/></joint>
    </robot>"""
    pm = pin.buildModelFromXML(urdf.replace("JOINT", joint))
    tree = LinkTree(SimpleNamespace(pin_model=pm))
    assert tree._plan is None
    q = pin.randomConfiguration(pm, -np.ones(pm.nq), np.ones(pm.nq)) if joint == "continuous" else np.array([0.3, -1.1])
    _same(tree.transforms(q), tree.transforms_pinocchio(q))
    assert len(tree.transforms(q)) == 2


def _pinocchio_quaternion(R: np.ndarray) -> np.ndarray:
    q = pin.Quaternion(np.array(R, dtype=float))
    q.normalize()
    return np.array([q.x, q.y, q.z, q.w])


unit_quaternions = st.tuples(*[st.floats(-1.0, 1.0)] * 4).filter(lambda v: sum(c * c for c in v) > 1e-6)


@pytest.mark.slow
@settings(max_examples=400, deadline=None)
@given(unit_quaternions, st.sampled_from([None, 0, 1, 2]))
def test_rotation_to_quaternion_is_pinocchios_conversion(v, half_turn_axis):
    """Plain-float conversion = Eigen's (Pinocchio's), same sign, within 4.5e-16 (two units
    in the last place of 1.0); half turns (trace -1, the branch on the largest diagonal
    entry) included."""
    if half_turn_axis is None:
        x, y, z, w = v
    else:  # a half turn about an axis: w = 0
        x, y, z, w = [c if i != 3 else 0.0 for i, c in enumerate(v)]
        if x * x + y * y + z * z < 1e-6:
            x, y, z = [1.0 if i == half_turn_axis else 0.0 for i in range(3)]
    R = pin.Quaternion(w, x, y, z).normalized().matrix()
    ours = rotation_to_quaternion(R.tolist())
    assert ours is not None
    assert np.abs(np.array(ours) - _pinocchio_quaternion(R)).max() <= 4.5e-16


def test_any_finite_matrix_converts_as_pinocchio_does_and_non_finite_falls_back():
    """Eigen's conversion of a matrix that is no rotation (as a bad pose would give) is
    kept too; a non-finite one goes to Pinocchio, as before."""
    bad = np.eye(4)
    bad[:3, :3] = [[-1.0, 0.2, 0.0], [0.0, -1.0, 0.5], [0.3, 0.0, -3.0]]
    assert (
        np.abs(np.array(pose_to_transform("a", "b", bad).rotation) - _pinocchio_quaternion(bad[:3, :3])).max() < 1e-15
    )
    nan = np.full((4, 4), np.nan)
    assert rotation_to_quaternion(nan.tolist()) is None
    tr = pose_to_transform("a", "b", nan)
    assert all(math.isnan(c) for c in tr.translation)
    assert np.array(tr.rotation).shape == (4,)
