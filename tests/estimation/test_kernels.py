"""Kalman kernels: closed-form steady state, Joseph-form invariants, gating and shape errors."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from postcapture.estimation import kernels as kalman
from postcapture.core.errors import CovarianceError, DimensionError


@pytest.mark.parametrize("q, r", [(1.0, 1.0), (0.01, 4.0), (2.5, 0.1)])
def test_scalar_random_walk_reaches_the_riccati_steady_state_gain(q, r):
    """x(k+1) = x(k) + w, z = x + v: the steady-state prior variance M solves M^2 - q M - q r = 0,

    M = (q + sqrt(q^2 + 4 q r)) / 2, and the gain is K = M / (M + r) (closed form).
    """
    M = 0.5 * (q + np.sqrt(q * q + 4.0 * q * r))
    K_ss, P_ss = M / (M + r), M * r / (M + r)
    rng = np.random.default_rng(11)
    x_true, x, P = 0.0, np.zeros(1), np.array([[100.0]])
    F, Q, H, R = np.eye(1), np.array([[q]]), np.eye(1), np.array([[r]])
    for _ in range(300):
        x_true += np.sqrt(q) * rng.standard_normal()
        x, P = kalman.predict(x, P, F, Q)
        z = x_true + np.sqrt(r) * rng.standard_normal()
        res = kalman.update(x, P, np.array([z]) - H @ x, H, R)
        x, P = res.x, res.P
    assert res.K[0, 0] == pytest.approx(K_ss, rel=1e-12)
    assert P[0, 0] == pytest.approx(P_ss, rel=1e-12)


def test_scalar_random_walk_error_variance_matches_P():
    """The empirical error variance over a long run agrees with the steady-state P (10 %)."""
    q, r = 0.5, 2.0
    rng = np.random.default_rng(12)
    kf = kalman.KalmanFilter(np.zeros(1), np.eye(1))
    x_true, errors = 0.0, []
    for k in range(6000):
        x_true += np.sqrt(q) * rng.standard_normal()
        kf.predict(np.eye(1), np.array([[q]]))
        kf.update(np.array([x_true + np.sqrt(r) * rng.standard_normal()]) - kf.x, np.eye(1), np.array([[r]]))
        if k > 100:
            errors.append(kf.x[0] - x_true)
    assert np.var(errors) == pytest.approx(kf.P[0, 0], rel=0.1)


def test_object_and_procedural_forms_agree():
    rng = np.random.default_rng(13)
    n, m = 4, 2
    F = np.eye(n) + 0.1 * rng.standard_normal((n, n))
    Q, R = 0.01 * np.eye(n), 0.1 * np.eye(m)
    H = rng.standard_normal((m, n))
    kf = kalman.KalmanFilter(np.zeros(n), np.eye(n))
    x, P = np.zeros(n), np.eye(n)
    for _ in range(10):
        z = rng.standard_normal(m)
        x, P = kalman.predict(x, P, F, Q)
        res = kalman.update(x, P, z - H @ x, H, R)
        x, P = res.x, res.P
        kf.predict(F, Q)
        kf.update(z - H @ kf.x, H, R)
    assert np.array_equal(kf.x, x) and np.array_equal(kf.P, P)


def _spd(n, seed_matrix, floor):
    A = seed_matrix[:n, :n]
    return A @ A.T + floor * np.eye(n)


entries = st.floats(-10.0, 10.0, allow_nan=False, allow_subnormal=False)


@settings(max_examples=150, deadline=None)
@given(
    n=st.integers(1, 6),
    m=st.integers(1, 3),
    A=arrays(np.float64, (6, 6), elements=entries),
    B=arrays(np.float64, (3, 3), elements=entries),
    H=arrays(np.float64, (3, 6), elements=entries),
    nu=arrays(np.float64, 3, elements=entries),
    p_floor=st.floats(1e-3, 10.0),
    r_floor=st.floats(1e-3, 10.0),
)
def test_joseph_update_keeps_P_symmetric_positive_definite(n, m, A, B, H, nu, p_floor, r_floor):
    P, R = _spd(n, A, p_floor), _spd(m, B, r_floor)
    res = kalman.update(np.zeros(n), P, nu[:m], H[:m, :n], R)
    assert np.array_equal(res.P, res.P.T)
    assert np.all(np.isfinite(res.P))
    np.linalg.cholesky(res.P)  # raises if not positive definite
    # an update never increases the variance along any direction
    assert np.min(np.linalg.eigvalsh(P - res.P)) > -1e-9 * np.max(np.abs(P))


def test_gate_rejects_a_100_sigma_outlier_and_accepts_a_1_sigma_sample():
    P, R, H = np.eye(3) * 1e-4, np.eye(3) * 1e-4, np.eye(3)
    sigma = np.sqrt(2e-4)  # innovation standard deviation per axis
    out = kalman.update(np.zeros(3), P, np.array([100 * sigma, 0, 0]), H, R, gate_probability=0.9999)
    assert not out.accepted
    assert out.nis == pytest.approx(1e4)
    assert np.array_equal(out.x, np.zeros(3)) and np.array_equal(out.P, P)
    assert out.threshold == pytest.approx(21.10751, rel=1e-5)  # chi2.ppf(0.9999, 3)
    ok = kalman.update(np.zeros(3), P, np.array([sigma, 0, 0]), H, R, gate_probability=0.9999)
    assert ok.accepted and ok.nis == pytest.approx(1.0)


@pytest.mark.parametrize(
    "args, match",
    [
        (
            (np.zeros(2), np.eye(3), np.ones(1), np.ones((1, 2)), np.eye(1)),
            r"P matrix; expected \(2, 2\) but found \(3, 3\)",
        ),
        (
            (np.zeros(2), np.eye(2), np.ones(1), np.ones((2, 2)), np.eye(1)),
            r"H matrix; expected \(1, 2\) but found \(2, 2\)",
        ),
        (
            (np.zeros(2), np.eye(2), np.ones(2), np.ones((2, 2)), np.eye(3)),
            r"R matrix; expected \(2, 2\) but found \(3, 3\)",
        ),
    ],
)
def test_update_shape_errors_name_the_matrix(args, match):
    with pytest.raises(DimensionError, match=match):
        kalman.update(*args)


def test_predict_shape_errors_name_the_matrix():
    with pytest.raises(DimensionError, match=r"F matrix; expected \(2, 2\) but found \(2, 3\)"):
        kalman.predict(np.zeros(2), np.eye(2), np.ones((2, 3)), np.eye(2))
    with pytest.raises(DimensionError, match=r"Q matrix"):
        kalman.predict(np.zeros(2), np.eye(2), np.eye(2), np.eye(3))
    with pytest.raises(DimensionError, match=r"x vector"):
        kalman.predict(np.zeros((2, 1)), np.eye(2), np.eye(2), np.eye(2))


def test_indefinite_innovation_covariance_raises():
    with pytest.raises(CovarianceError, match="not positive definite"):
        kalman.update(np.zeros(1), np.eye(1), np.ones(1), np.eye(1), -2.0 * np.eye(1))
    with pytest.raises(CovarianceError, match="not finite"):
        kalman.update(np.zeros(1), np.full((1, 1), np.nan), np.ones(1), np.eye(1), np.eye(1))


def test_bad_gate_probability_raises():
    with pytest.raises(ValueError, match="gate_probability"):
        kalman.update(np.zeros(1), np.eye(1), np.ones(1), np.eye(1), np.eye(1), gate_probability=1.0)


def test_schmidt_consider_update_against_the_scalar_closed_form():
    """z = x + c + v with c a consider parameter: x takes the gain (Px + Pxc) / S, c keeps its value and variance.

    With S = Px + 2 Pxc + Pc + R and Kx = (Px + Pxc) / S: Px+ = Px - (Px + Pxc)^2 / S,
    Pxc+ = Pxc - Kx (Pxc + Pc), Pc+ = Pc (Schmidt; Bierman, Factorization Methods, 1977, ch. VIII).
    """
    Px, Pxc, Pc, R = 4.0, 0.5, 2.0, 1.5
    P = np.array([[Px, Pxc], [Pxc, Pc]])
    nu = np.array([0.7])
    res = kalman.update(np.array([1.0, -2.0]), P, nu, np.array([[1.0, 1.0]]), np.array([[R]]), consider=[1])
    S = Px + 2 * Pxc + Pc + R
    Kx = (Px + Pxc) / S
    assert res.x == pytest.approx([1.0 + Kx * 0.7, -2.0], rel=1e-14)
    assert res.P[0, 0] == pytest.approx(Px - (Px + Pxc) ** 2 / S, rel=1e-14)
    assert res.P[0, 1] == pytest.approx(Pxc - Kx * (Pxc + Pc), rel=1e-14)
    assert res.P[1, 1] == pytest.approx(Pc, rel=1e-14)
    # the consider filter is more cautious than the full one, which would also move c and shrink Pc
    full = kalman.update(np.array([1.0, -2.0]), P, nu, np.array([[1.0, 1.0]]), np.array([[R]]))
    assert full.P[1, 1] < Pc and res.P[0, 0] >= full.P[0, 0]
