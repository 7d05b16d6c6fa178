"""Star tracker: cross-boresight and roll error statistics, body-frame convention, dropouts."""

import numpy as np
import pytest

from postcapture.core import rotations as rot
from postcapture.core.errors import DimensionError, ScenarioError
from postcapture.sensors import StarTrackerParams, measure_star_tracker


def spin_truth(n, dt=0.1):
    t = np.arange(n) * dt
    q0 = rot.normalize(np.array([0.7, 0.1, -0.5, 0.3]))
    q = rot.box_plus(np.repeat(q0[:, None], n, axis=1), np.array([[0.02], [-0.05], [0.1]]) * t)
    return t, q


def test_cross_and_roll_sigmas_about_an_oblique_boresight():
    n = 40_000
    t, q = spin_truth(n)
    boresight = np.array([1.0, 1.0, 1.0]) / np.sqrt(3.0)
    p = StarTrackerParams(sigma_cross=1e-5, sigma_roll=8e-5, rate=10.0, boresight_B=boresight)
    m = measure_star_tracker(p, t, q, rng=np.random.default_rng(41))
    assert m.values.shape == (4, n) and np.all(m.values[0] >= 0)
    # the error is a body-frame right perturbation of the truth
    d = rot.box_minus(m.values, q)
    assert np.allclose(d, m.truth["dtheta_B"], atol=1e-12)
    roll = boresight @ d
    cross = d - np.outer(boresight, roll)
    assert np.std(roll) == pytest.approx(8e-5, rel=0.03)
    assert np.sqrt(np.mean(np.sum(cross**2, axis=0)) / 2.0) == pytest.approx(1e-5, rel=0.03)
    assert np.allclose(np.cov(d), p.covariance(), rtol=0.05, atol=1e-12)


def test_covariance_of_the_default_boresight():
    p = StarTrackerParams(sigma_cross=2.0, sigma_roll=10.0)
    assert np.allclose(p.covariance(), np.diag([4.0, 4.0, 100.0]))
    axes = p.sensor_axes_B()
    assert np.allclose(axes.T @ axes, np.eye(3)) and np.allclose(axes[:, 2], [0, 0, 1])


def test_dropouts_are_nan_and_flagged():
    t, q = spin_truth(2001, dt=0.05)
    p = StarTrackerParams(1e-5, 5e-5, rate=4.0, dropout_probability=0.25)
    m = measure_star_tracker(p, t, q, rng=np.random.default_rng(42))
    assert m.n_samples == 401 and np.allclose(np.diff(m.t), 0.25)
    assert np.all(np.isnan(m.values[:, ~m.valid])) and 0.15 < m.n_missing / m.n_samples < 0.35


def test_bad_inputs_raise():
    with pytest.raises(ScenarioError, match="StarTrackerParams.boresight_B") as info:
        StarTrackerParams(sigma_cross=-1.0, sigma_roll=1.0, boresight_B=[0.0, 0.0, 0.0])
    assert "StarTrackerParams.sigma_cross" in str(info.value)
    t = np.arange(11) * 0.1
    with pytest.raises(DimensionError, match=r"q_BN` must have shape \(4, n_t\)"):
        measure_star_tracker(StarTrackerParams(1e-5, 1e-5), t, np.ones((3, 11)), rng=np.random.default_rng(0))
