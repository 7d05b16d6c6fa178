"""Farrenkopf's closed form against the discrete algebraic Riccati equation."""

import numpy as np
import pytest
from scipy.linalg import solve_discrete_are

from postcapture.core.farrenkopf import farrenkopf_steady_state


@pytest.mark.parametrize(
    "sigma_n, sigma_v, sigma_u, dt",
    [
        (9.7e-6, 5.8e-7, 8.1e-10, 0.1),  # realistic profile, cross-boresight
        (4.8e-5, 5.8e-7, 8.1e-10, 1.0),
        (0.01, np.sqrt(10) * 1e-7, np.sqrt(10) * 1e-10, 0.1),  # reference profile
        (1e-4, 1e-4, 1e-6, 0.5),  # bias walk comparable with the sensor noise
    ],
)
def test_closed_form_equals_the_riccati_steady_state(sigma_n, sigma_v, sigma_u, dt):
    F = np.array([[1.0, -dt], [0.0, 1.0]])
    Q = np.array([[sigma_v**2 * dt + sigma_u**2 * dt**3 / 3, -(sigma_u**2) * dt**2 / 2],
                  [-(sigma_u**2) * dt**2 / 2, sigma_u**2 * dt]])
    H, R = np.array([[1.0, 0.0]]), np.array([[sigma_n**2]])
    M = solve_discrete_are(F.T, H.T, Q, R)  # prior (pre-update) steady state
    P = M - M @ H.T @ H @ M / (M[0, 0] + sigma_n**2)
    f = farrenkopf_steady_state(sigma_n, sigma_v, sigma_u, dt)
    assert f.attitude_pre == pytest.approx(np.sqrt(M[0, 0]), rel=1e-8)
    assert f.attitude_post == pytest.approx(np.sqrt(P[0, 0]), rel=1e-8)
    assert f.bias_pre == pytest.approx(np.sqrt(M[1, 1]), rel=1e-6)
    assert f.bias_post == pytest.approx(np.sqrt(P[1, 1]), rel=1e-6)


def test_limits():
    # no gyro noise at all: the attitude becomes perfectly known
    assert farrenkopf_steady_state(1e-5, 0.0, 0.0, 0.1).attitude_post == 0.0
    with pytest.raises(ValueError):
        farrenkopf_steady_state(0.0, 1e-6, 1e-9, 0.1)
