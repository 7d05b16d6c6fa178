"""Gyro model: Allan variance and bias-walk statistics against sigma_v and sigma_u."""

import numpy as np
import pytest

from postcapture.core.errors import ScenarioError, TimeGridError
from postcapture.sensors import GyroParams, measure_gyro

DT = 0.1
N = 200_001
T = np.arange(N) * DT


def allan_variance(y, dt, m):
    """Overlapping Allan variance of rate samples ``y`` (each the mean over ``dt``) at ``tau = m dt``."""
    theta = np.concatenate([[0.0], np.cumsum(y)]) * dt
    d = theta[2 * m:] - 2.0 * theta[m:-m] + theta[:-2 * m]
    tau = m * dt
    return np.mean(d * d) / (2.0 * tau * tau)


def mean_avar(g, m):
    return np.mean([allan_variance(g.values[i], DT, m) for i in range(3)])


@pytest.mark.parametrize("m", [1, 10, 100])
def test_angle_random_walk_allan_variance(m):
    """White rate noise: AVAR(tau) = sigma_v^2 / tau."""
    sigma_v = 1e-4
    p = GyroParams(sigma_v, 0.0, rate=1 / DT)
    g = measure_gyro(p, T, np.zeros((3, N)), rng=np.random.default_rng(31))
    assert mean_avar(g, m) == pytest.approx(sigma_v**2 / (m * DT), rel=0.05)


@pytest.mark.parametrize("m", [1, 10, 100])
def test_bias_random_walk_allan_variance(m):
    """Rate random walk: AVAR(tau) = sigma_u^2 tau / 3 (exact for the discrete model at every tau)."""
    sigma_u = 1e-5
    p = GyroParams(0.0, sigma_u, rate=1 / DT)
    g = measure_gyro(p, T, np.zeros((3, N)), rng=np.random.default_rng(32))
    assert mean_avar(g, m) == pytest.approx(sigma_u**2 * m * DT / 3.0, rel=0.05)


def test_combined_noise_bias_increments_and_white_part():
    sigma_v, sigma_u = 3e-5, 2e-6
    omega = np.array([[0.01], [-0.02], [0.03]]) * np.ones((1, N))
    g = measure_gyro(GyroParams(sigma_v, sigma_u, rate=1 / DT, initial_bias_B=[1e-3, 0, -1e-3]), T, omega,
                     rng=np.random.default_rng(33))
    b = g.truth["bias_B"]
    assert np.allclose(b[:, 0], [1e-3, 0, -1e-3])
    assert np.std(np.diff(b, axis=1)) == pytest.approx(sigma_u * np.sqrt(DT), rel=0.01)
    white = g.values[:, :-1] - omega[:, :-1] - 0.5 * (b[:, :-1] + b[:, 1:])
    assert np.std(white) == pytest.approx(np.sqrt(sigma_v**2 / DT + sigma_u**2 * DT / 12), rel=0.01)
    tau_c = np.sqrt(3.0) * sigma_v / sigma_u  # where both terms are equal
    m = int(round(tau_c / DT))
    expected = sigma_v**2 / (m * DT) + sigma_u**2 * m * DT / 3
    assert mean_avar(g, m) == pytest.approx(expected, rel=0.08)


def test_sample_rate_and_dropouts():
    t = np.arange(1001) * 0.01  # 100 Hz truth
    p = GyroParams(1e-6, 0.0, rate=20.0, dropout_probability=0.3)
    g = measure_gyro(p, t, np.zeros((3, t.size)), rng=np.random.default_rng(34))
    assert np.allclose(g.t, np.arange(201) / 20.0) and g.rate == 20.0
    assert np.all(np.isnan(g.values[:, ~g.valid])) and np.all(np.isfinite(g.values[:, g.valid]))
    assert 0.2 < g.n_missing / g.n_samples < 0.4
    # dropouts are drawn after the noise: the kept samples are those of a run without dropouts
    p0 = GyroParams(1e-6, 0.0, rate=20.0)
    g0 = measure_gyro(p0, t, np.zeros((3, t.size)), rng=np.random.default_rng(34))
    assert np.array_equal(g.values[:, g.valid], g0.values[:, g.valid])


def test_instants_off_the_truth_grid_raise():
    t = np.arange(101) * 0.1
    with pytest.raises(TimeGridError, match="gyro sample times at 3 Hz"):
        measure_gyro(GyroParams(1e-6, 0.0, rate=3.0), t, np.zeros((3, t.size)), rng=np.random.default_rng(0))


def test_invalid_parameters_name_every_field():
    with pytest.raises(ScenarioError, match="4 problems") as info:
        GyroParams(sigma_v=-1.0, sigma_u=float("nan"), rate=0.0, dropout_probability=1.0)
    text = str(info.value)
    for name in ("sigma_v", "sigma_u", "rate", "dropout_probability"):
        assert f"GyroParams.{name}" in text
    with pytest.raises(ValueError, match="initial_bias_B"):
        GyroParams(1e-6, 1e-9, initial_bias_B=[0.0, 1.0])
