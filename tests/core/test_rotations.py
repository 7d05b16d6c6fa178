"""Properties and pinning tests of the quaternion conventions in ``postcapture.core.rotations``."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays
from scipy.spatial.transform import Rotation

from postcapture.core import rotations as rot

finite = st.floats(-1.0, 1.0, allow_nan=False, allow_subnormal=False)
raw_quat = arrays(np.float64, 4, elements=finite).filter(lambda q: np.linalg.norm(q) > 1e-3)
quats = raw_quat.map(rot.normalize)
# rotation vectors shorter than pi - 1e-3, where box_minus(box_plus(q, d), q) == d is well defined
rot_vec = arrays(np.float64, 3, elements=st.floats(-1.8, 1.8, allow_nan=False, allow_subnormal=False)).filter(
    lambda v: np.linalg.norm(v) < np.pi - 1e-3
)
SETTINGS = settings(max_examples=100, deadline=None)


def same_rotation(q1, q2, atol=1e-12):
    """Quaternions equal up to the sign ambiguity q ~ -q."""
    return min(np.max(np.abs(q1 - q2)), np.max(np.abs(q1 + q2))) < atol


@SETTINGS
@given(raw_quat)
def test_normalize_gives_unit_norm_and_nonnegative_scalar(q):
    qn = rot.normalize(q)
    assert abs(np.linalg.norm(qn) - 1.0) < 1e-14
    assert qn[0] >= 0.0
    assert same_rotation(qn, q / np.linalg.norm(q))


@SETTINGS
@given(quats)
def test_quaternion_times_inverse_is_identity(q):
    assert np.allclose(rot.compose(rot.conjugate(q), q), rot.IDENTITY, atol=1e-14)
    assert np.allclose(rot.compose(q, rot.conjugate(q)), rot.IDENTITY, atol=1e-14)


@SETTINGS
@given(quats)
def test_dcm_quat_round_trip(q):
    C = rot.dcm_from_quat(q)
    assert np.allclose(C @ C.T, np.eye(3), atol=1e-13)
    assert abs(np.linalg.det(C) - 1.0) < 1e-13
    assert same_rotation(rot.quat_from_dcm(C), q, atol=1e-12)


@SETTINGS
@given(quats)
def test_dcm_pinned_to_scipy_passive_convention(q_BN):
    """Required pinning test: our passive C_BN is the transpose of scipy's active matrix."""
    expected = Rotation.from_quat(q_BN, scalar_first=True).as_matrix().T
    assert np.allclose(rot.dcm_from_quat(q_BN), expected, atol=1e-14)


@SETTINGS
@given(quats, quats)
def test_compose_follows_the_frame_chain(q_CB, q_BN):
    """compose(q_CB, q_BN) is the quaternion of C_CB @ C_BN."""
    q_CN = rot.compose(q_CB, q_BN)
    C_CN = rot.dcm_from_quat(q_CB) @ rot.dcm_from_quat(q_BN)
    assert np.allclose(rot.dcm_from_quat(q_CN), C_CN, atol=1e-13)
    assert same_rotation(q_CN, rot.quat_from_dcm(C_CN), atol=1e-12)
    assert q_CN[0] >= 0.0


@SETTINGS
@given(quats, rot_vec)
def test_box_minus_inverts_box_plus(q, d):
    q2 = rot.box_plus(q, d)
    assert np.allclose(rot.box_minus(q2, q), d, atol=1e-9)
    assert same_rotation(rot.box_plus(q, rot.box_minus(q2, q)), q2, atol=1e-12)


@SETTINGS
@given(rot_vec)
def test_exp_log_round_trip(d):
    assert np.allclose(rot.log_map(rot.exp_map(d)), d, atol=1e-9)
    assert abs(np.linalg.norm(rot.exp_map(d)) - 1.0) < 1e-14


def test_passive_dcm_of_a_rotation_about_z():
    """B is N turned by +a about z: N's x axis has B components (cos a, -sin a, 0)."""
    a = 0.3
    C_BN = rot.dcm_from_quat(rot.exp_map(np.array([0.0, 0.0, a])))
    expected = np.array([[np.cos(a), np.sin(a), 0.0], [-np.sin(a), np.cos(a), 0.0], [0.0, 0.0, 1.0]])
    assert np.allclose(C_BN, expected, atol=1e-15)


def test_box_plus_is_a_body_frame_perturbation():
    """box_plus(q_BN, d) == compose(exp(d), q_BN): C_B'N = C_B'B @ C_BN with C_B'B = C(exp(d))."""
    rng = np.random.default_rng(3)
    q = rot.normalize(rng.standard_normal(4))
    d = 0.1 * rng.standard_normal(3)
    C = rot.dcm_from_quat(rot.box_plus(q, d))
    assert np.allclose(C, rot.dcm_from_quat(rot.exp_map(d)) @ rot.dcm_from_quat(q), atol=1e-14)


def test_vectorised_histories_match_single_quaternions():
    rng = np.random.default_rng(4)
    q = rot.normalize(rng.standard_normal((4, 7)))
    d = 0.2 * rng.standard_normal((3, 7))
    qp = rot.box_plus(q, d)
    dm = rot.box_minus(qp, q)
    for k in range(7):
        assert np.allclose(qp[:, k], rot.box_plus(q[:, k], d[:, k]), atol=1e-15)
        assert np.allclose(dm[:, k], rot.box_minus(qp[:, k], q[:, k]), atol=1e-14)
    assert np.all(qp[0] >= 0.0)


def test_constant_rate_spin_matches_quat_rate():
    """q(t) = box_plus(q0, w t) solves dq/dt = quat_rate(q, w) (central difference)."""
    rng = np.random.default_rng(5)
    q0 = rot.normalize(rng.standard_normal(4))
    w = np.array([0.02, -0.03, 0.05])
    t, h = 7.0, 1e-4
    q = rot.box_plus(q0, w * t)
    qdot = (rot.box_plus(q0, w * (t + h)) - rot.box_plus(q0, w * (t - h))) / (2 * h)
    assert np.allclose(qdot, rot.quat_rate(q, w), atol=1e-9)


@pytest.mark.parametrize("xyzw", [[0.0, 0.0, 0.0, 1.0], [0.1, -0.2, 0.3, -0.9]])
def test_pinocchio_order_round_trip(xyzw):
    q = rot.quat_from_pinocchio(xyzw)
    back = rot.quat_to_pinocchio(q)
    assert same_rotation(back, np.asarray(xyzw) / np.linalg.norm(xyzw))
    assert q[0] >= 0.0
