"""Accelerometer, joint sensors, the Measurements record and the named profiles."""

import dataclasses

import numpy as np
import pytest

from postcapture.core.errors import DimensionError, ScenarioError
from postcapture.core.units import ARCSEC, DEG_PER_HOUR
from postcapture.sensors import (
    AccelerometerParams,
    JointSensorParams,
    Measurements,
    get_profile,
    measure_accelerometer,
    measure_joint_accelerations,
)


def test_accelerometer_noise_bias_and_bias_walk():
    n = 100_001
    t = np.arange(n) * 0.01
    f = np.vstack([np.sin(t), np.cos(t), 0.0 * t]) * 1e-3
    p = AccelerometerParams(sigma=2e-4, rate=100.0, bias_B=[1e-4, -2e-4, 3e-4], sigma_bias_walk=1e-6)
    m = measure_accelerometer(p, t, f, rng=np.random.default_rng(51))
    b = m.truth["bias_B"]
    assert np.allclose(b[:, 0], [1e-4, -2e-4, 3e-4])
    assert np.std(np.diff(b, axis=1)) == pytest.approx(1e-6 * np.sqrt(0.01), rel=0.02)
    assert np.std(m.values - f - b) == pytest.approx(2e-4, rel=0.01)
    const = measure_accelerometer(AccelerometerParams(sigma=0.0, bias_B=[1.0, 2.0, 3.0], rate=100.0), t, f,
                                  rng=np.random.default_rng(0))
    assert np.allclose(const.values - f, np.array([[1.0], [2.0], [3.0]]))


def test_joint_accelerations_noise_and_shape_check():
    t = np.arange(2001) * 0.005
    qdd = np.outer(np.arange(1, 8), np.sin(t))
    p = JointSensorParams(sigma=0.1, rate=10.0)
    m = measure_joint_accelerations(p, t, qdd, rng=np.random.default_rng(52))
    assert m.values.shape == (7, 101) and m.units == ("rad/s^2",) * 7
    assert np.allclose(m.truth["qdd"], qdd[:, ::20])
    assert np.std(m.values - m.truth["qdd"]) == pytest.approx(0.1, rel=0.1)
    with pytest.raises(DimensionError, match=r"qdd` must have shape \(7, n_t\)"):
        measure_joint_accelerations(JointSensorParams(0.1), t, qdd[:6], rng=np.random.default_rng(0))


def test_measurements_record_checks_shapes():
    with pytest.raises(DimensionError, match=r"`values` must have shape \(m, 3\)"):
        Measurements("x", [0.0, 1.0, 2.0], np.zeros((2, 4)), np.ones(3, bool), "m", 1.0)
    with pytest.raises(DimensionError, match="units"):
        Measurements("x", [0.0, 1.0], np.zeros((2, 2)), np.ones(2, bool), ("m", "s", "kg"), 1.0)


def test_profiles():
    ref, real = get_profile("reference"), get_profile("realistic")
    assert np.allclose(ref.star_tracker.covariance(), 0.01**2 * np.eye(3))
    # navigation grade: 10 micro-g / sqrt(Hz) at 10 Hz; joints 1e-3 rad/s^2 (the reference gives no numbers)
    assert ref.accelerometer.sigma == pytest.approx(10e-6 * 9.80665 * np.sqrt(10.0), rel=1e-9)
    assert ref.joints.sigma == pytest.approx(1e-3)
    assert real.star_tracker.sigma_cross == pytest.approx(2 * ARCSEC)
    assert real.star_tracker.sigma_roll == pytest.approx(10 * ARCSEC)
    assert real.gyro.sigma_v == pytest.approx(5.8178e-7, rel=1e-4)  # 0.002 deg/sqrt(h)
    # the bias walk drifts 0.01 deg/h (1 sigma) in one hour
    assert real.gyro.sigma_u * np.sqrt(3600.0) == pytest.approx(0.01 * DEG_PER_HOUR)
    tweaked = dataclasses.replace(real.gyro, rate=100.0)
    assert tweaked.rate == 100.0 and tweaked.sigma_v == real.gyro.sigma_v
    with pytest.raises(ScenarioError, match="'reference' or 'realistic'"):
        get_profile("optimistic")
