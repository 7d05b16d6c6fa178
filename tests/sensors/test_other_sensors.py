"""Accelerometer, joint encoders, the Measurements record and the named profiles."""

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
    measure_joint_angles,
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


def test_accelerometer_scale_factor_and_misalignment():
    """Noise-free readings are ``(I + diag(s) + M) f + b``, axis by axis (a closed form)."""
    t = np.arange(11) * 0.1
    f = np.vstack([np.full(11, 0.01), np.full(11, -0.02), np.full(11, 0.005)])
    M = np.array([[0.0, 1e-3, -2e-3], [3e-3, 0.0, 4e-4], [-1e-3, 5e-4, 0.0]])
    p = AccelerometerParams(sigma=0.0, bias_B=[1e-4, 0.0, 0.0], scale_factor=[1e-3, -2e-3, 5e-4], misalignment=M)
    m = measure_accelerometer(p, t, f, rng=np.random.default_rng(0))
    x, y, z = 0.01, -0.02, 0.005
    expected = [x * (1 + 1e-3) + 1e-3 * y - 2e-3 * z + 1e-4, 3e-3 * x + y * (1 - 2e-3) + 4e-4 * z,
                -1e-3 * x + 5e-4 * y + z * (1 + 5e-4)]
    assert np.allclose(m.values[:, 3], expected, rtol=0, atol=1e-15)
    with pytest.raises(ScenarioError, match="misalignment"):
        AccelerometerParams(sigma=0.0, misalignment=np.eye(3) * 1e-3)  # the diagonal is the scale factor's


def test_encoders_quantise_and_check_their_shape():
    t = np.arange(2001) * 0.005
    q = np.outer(np.arange(1, 8), np.sin(t)) * 0.1
    res = 2 * np.pi / 2**20
    p = JointSensorParams(sigma=0.0, resolution=res, rate=10.0)
    m = measure_joint_angles(p, t, q, rng=np.random.default_rng(52))
    assert m.values.shape == (7, 101) and m.units == ("rad",) * 7
    assert np.allclose(m.truth["q_arm"], q[:, ::20])
    counts = m.values / res
    assert np.allclose(counts, np.round(counts), atol=1e-6)  # whole counts
    err = m.values - m.truth["q_arm"]
    assert np.max(np.abs(err)) <= 0.5 * res * (1 + 1e-9)
    assert np.std(err) == pytest.approx(res / np.sqrt(12.0), rel=0.1)  # uniform quantisation error
    noisy = JointSensorParams(sigma=1e-5, resolution=res)
    assert noisy.sample_sigma == pytest.approx(np.sqrt(1e-10 + res**2 / 12))
    m = measure_joint_angles(noisy, t, q, rng=np.random.default_rng(53))
    assert np.std(m.values - m.truth["q_arm"]) == pytest.approx(noisy.sample_sigma, rel=0.1)
    with pytest.raises(DimensionError, match=r"q_arm` must have shape \(7, n_t\)"):
        measure_joint_angles(JointSensorParams(0.1), t, q[:6], rng=np.random.default_rng(0))


def test_measurements_record_checks_shapes():
    with pytest.raises(DimensionError, match=r"`values` must have shape \(m, 3\)"):
        Measurements("x", [0.0, 1.0, 2.0], np.zeros((2, 4)), np.ones(3, bool), "m", 1.0)
    with pytest.raises(DimensionError, match="units"):
        Measurements("x", [0.0, 1.0], np.zeros((2, 2)), np.ones(2, bool), ("m", "s", "kg"), 1.0)


def test_profiles():
    ref, real = get_profile("reference"), get_profile("realistic")
    assert np.allclose(ref.star_tracker.covariance(), 0.01**2 * np.eye(3))
    # navigation grade: 10 micro-g / sqrt(Hz) at 10 Hz; 20-bit encoders (the reference gives no numbers)
    assert ref.accelerometer.sigma == pytest.approx(10e-6 * 9.80665 * np.sqrt(10.0), rel=1e-9)
    assert ref.joints.resolution == pytest.approx(2 * np.pi / 2**20) and ref.joints == real.joints
    assert not np.any(ref.gyro.scale_factor) and not np.any(ref.gyro.misalignment)
    # Astrix 120: 100 ppm scale factor (datasheet) as the 1-sigma the filters assume; this unit's errors
    assert real.gyro.scale_factor_sigma == pytest.approx(100e-6)
    assert 0 < np.max(np.abs(real.gyro.scale_factor)) < 3 * 100e-6
    assert real.star_tracker.sigma_cross == pytest.approx(2 * ARCSEC)
    assert real.star_tracker.sigma_roll == pytest.approx(10 * ARCSEC)
    assert real.gyro.sigma_v == pytest.approx(5.8178e-7, rel=1e-4)  # 0.002 deg/sqrt(h)
    # the bias walk drifts 0.01 deg/h (1 sigma) in one hour
    assert real.gyro.sigma_u * np.sqrt(3600.0) == pytest.approx(0.01 * DEG_PER_HOUR)
    tweaked = dataclasses.replace(real.gyro, rate=100.0)
    assert tweaked.rate == 100.0 and tweaked.sigma_v == real.gyro.sigma_v
    with pytest.raises(ScenarioError, match="'reference' or 'realistic'"):
        get_profile("optimistic")


def test_an_accelerometer_scale_step_multiplies_the_true_specific_force():
    from types import SimpleNamespace

    from postcapture.sensors.faults import apply_faults

    t = np.arange(101) * 0.1
    f = np.vstack([0.01 + 0.0 * t, np.sin(t) * 1e-3, 0.0 * t])
    rec = measure_accelerometer(AccelerometerParams(sigma=1e-4, bias_B=[1e-4, 0, 0]), t, f,
                                rng=np.random.default_rng(4))
    fault = SimpleNamespace(kind="accelerometer_scale_step", time=5.0, step=(1e-3, -2e-3, 0.0))
    out = apply_faults({"accelerometer": rec}, [fault])["accelerometer"]
    before, after = t < 5.0, t >= 5.0
    np.testing.assert_array_equal(out.values[:, before], rec.values[:, before])
    expected = rec.values[:, after] + np.array([[1e-3], [-2e-3], [0.0]]) * f[:, after]
    np.testing.assert_allclose(out.values[:, after], expected, rtol=0, atol=1e-18)
