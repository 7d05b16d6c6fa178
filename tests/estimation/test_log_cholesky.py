"""The log-Cholesky map of inertial parameters: physical over random draws, invertible, exact Jacobian."""

import numpy as np
import pinocchio as pin
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from postcapture.core.log_cholesky import pseudo_inertia, theta_from_pi
from postcapture.estimation.parameters import dpi_dtheta, pi_from_theta

thetas = st.lists(st.floats(-3.0, 3.0), min_size=10, max_size=10).map(np.array)


def _body(pi):
    """Mass, CoM and inertia about the CoM through Pinocchio (an independent reading of the parameters)."""
    inertia = pin.Inertia.FromDynamicParameters(np.asarray(pi))
    return inertia.mass, inertia.lever, inertia.inertia


@settings(max_examples=200, deadline=None)
@given(thetas)
def test_every_theta_is_a_physical_body(theta):
    m, c, I_c = _body(pi_from_theta(theta))
    assert m > 0
    a, b, cc = np.linalg.eigvalsh(I_c)
    assert a > 0
    assert a + b >= cc * (1 - 1e-9)  # triangle inequality of the principal moments
    assert m == pytest.approx(np.exp(2 * theta[0]), rel=1e-12)


@settings(max_examples=200, deadline=None)
@given(thetas)
def test_inverse(theta):
    """The round trip is as accurate as the pseudo-inertia's conditioning allows: within 10 eps cond(J)
    (the worst of 20000 uniform draws was 3.7 eps cond; theta = [0, -3, -3, -3, 1, 3, 0, 0, 0, 0] has a
    condition number of 5e9 and comes back 1.6e-7 off)."""
    pi = pi_from_theta(theta)
    tol = 10.0 * np.finfo(float).eps * np.linalg.cond(pseudo_inertia(pi))
    np.testing.assert_allclose(theta_from_pi(pi), theta, rtol=1e-8, atol=tol)


def test_round_trip_of_a_real_body():
    inertia = pin.Inertia(7478.0, np.array([-0.2, 0.05, 0.4]), np.array([[9000.0, 300, -1500], [300, 90000, 200],
                                                                          [-1500, 200, 95000]]))
    pi = inertia.toDynamicParameters()
    np.testing.assert_allclose(pi_from_theta(theta_from_pi(pi)), pi, rtol=1e-11)
    assert np.all(np.linalg.eigvalsh(pseudo_inertia(pi)) > 0)


def test_a_body_that_cannot_exist_is_refused():
    pi = pin.Inertia(1.0, np.zeros(3), np.diag([1.0, 1.0, 3.0])).toDynamicParameters()  # 1 + 1 < 3
    with pytest.raises(ValueError, match="cannot exist"):
        theta_from_pi(pi)


def test_jacobian_against_finite_differences(rng=np.random.default_rng(5)):
    for _ in range(5):
        theta = rng.uniform(-1.0, 1.0, 10)
        fd = np.empty((10, 10))
        for k in range(10):
            e = np.zeros(10)
            e[k] = 1e-6
            fd[:, k] = (pi_from_theta(theta + e) - pi_from_theta(theta - e)) / 2e-6
        np.testing.assert_allclose(dpi_dtheta(theta), fd, rtol=1e-7, atol=1e-8 * np.abs(fd).max())
