"""The MEKF with the gyro's scale factors and misalignments (15 states) on a gyro that has them."""

import dataclasses

import numpy as np
import pytest

from postcapture.core import rotations as rot
from postcapture.core.units import ARCSEC
from postcapture.estimation import MEKFTuning
from postcapture.estimation.mekf import MEKF
from postcapture.estimation.filter import Measurement
from postcapture.sensors import get_profile, measure_gyro, measure_star_tracker

RATES = np.array([[0.03, 0.0, 0.01], [0.0, -0.035, 0.0], [0.01, 0.02, -0.03], [-0.02, 0.0, 0.025]])  # rad/s


def _truth(duration, dt=0.1):
    """Piecewise-constant body rates (each held for a quarter of the run): the attitude in closed form."""
    n = int(round(duration / dt)) + 1
    seg = (np.arange(n) * 4) // n
    w = RATES[np.minimum(seg, 3)].T  # (3, n): the rate over [t_k, t_k+1]
    q = np.empty((4, n))
    q[:, 0] = rot.normalize(np.array([0.9, 0.1, -0.3, 0.2]))
    for k in range(n - 1):
        q[:, k + 1] = rot.box_plus(q[:, k], w[:, k] * dt)
    return np.arange(n) * dt, q, w


def _run(seed, calibrated, duration=400.0):
    prof = get_profile("realistic")
    rng = np.random.default_rng(seed)
    scale = 100e-6 * rng.standard_normal(3)
    mis = np.zeros((3, 3))
    mis[~np.eye(3, dtype=bool)] = 50e-6 * rng.standard_normal(6)
    gyro_p = dataclasses.replace(prof.gyro, scale_factor=scale, misalignment=mis)
    t, q, w = _truth(duration)
    gyro = measure_gyro(gyro_p, t, w, rng=rng)
    star = measure_star_tracker(prof.star_tracker, t, q, rng=rng)
    tuning = MEKFTuning(gyro_p.sigma_v, gyro_p.sigma_u, prof.star_tracker.covariance())
    P0 = np.diag([(10 * ARCSEC) ** 2] * 3 + [(0.1 * np.pi / 180 / 3600) ** 2] * 3
                 + ([100e-6**2] * 3 + [50e-6**2] * 6 if calibrated else []))
    f = MEKF(tuning, q[:, 0], P0, bias0_B=np.zeros(3))
    nees = []
    for k in range(t.size - 1):
        f.predict(t[k], 0.1, gyro.values[:, k])
        f.update(Measurement("star_tracker", t[k + 1], star.values[:, k + 1], tuning.star_covariance))
        e = rot.box_minus(q[:, k + 1], f.q_BN)
        if t[k + 1] > 50.0:
            nees.append(e @ np.linalg.solve(f.P[:3, :3], e))
    truth_cal = np.concatenate([scale, mis[~np.eye(3, dtype=bool)]])
    return f, truth_cal, float(np.mean(nees))


def test_the_calibration_is_learnt_within_its_covariance():
    f, truth_cal, nees = _run(3, calibrated=True)
    sigma = np.sqrt(np.diag(f.P)[6:])
    err = f.calibration - truth_cal
    assert np.all(np.abs(err) < 3.5 * sigma), (err / sigma).round(2)
    assert np.all(sigma[:3] < 0.5 * 100e-6)  # the scale factors are learnt from the changing rates
    assert 1.5 < nees < 5.0, nees


@pytest.mark.parametrize("seed", [4, 5])
def test_without_the_calibration_states_the_attitude_is_overconfident(seed):
    """The six-state filter on the same gyro: its attitude NEES leaves the band the calibrated one keeps."""
    _, _, nees6 = _run(seed, calibrated=False)
    _, _, nees15 = _run(seed, calibrated=True)
    assert nees15 < 5.0 < nees6, (nees15, nees6)
