"""Shared truth for the estimation tests: a constant-rate spin with its closed-form attitude."""

import dataclasses

import numpy as np
import pytest

from postcapture.core import rotations as rot
from postcapture.estimation import MEKFTuning
from postcapture.sensors import get_profile, measure_gyro, measure_star_tracker


@dataclasses.dataclass
class SpinCase:
    """Truth, measurements and a matched tuning for one seed."""

    t: np.ndarray
    q_BN: np.ndarray
    gyro: object
    star: object
    tuning: MEKFTuning
    profile: object


def make_spin_case(n, *, seed, dt=0.1, omega_B=(0.0, 0.0, 0.01745), profile="realistic",
                   gyro_rate=None, initial_bias_B=None, q0=(0.9, 0.1, -0.3, 0.2), **tuning_kw):
    """Constant body rate ``omega_B`` (rad/s): ``q_BN(t) = box_plus(q0, omega_B t)`` (the exp map).

    The truth grid has step ``dt`` unless the gyro is faster; the star tracker samples every ``dt``.
    """
    prof = get_profile(profile)
    # the profile's noise and bias, without its scale-factor and misalignment errors: these tests hold the
    # six-state MEKF to closed forms (Farrenkopf's bound) that assume none (test_mekf_calibration has them)
    gyro_p = dataclasses.replace(prof.gyro, scale_factor=np.zeros(3), misalignment=np.zeros((3, 3)))
    if gyro_rate is not None:
        gyro_p = dataclasses.replace(gyro_p, rate=gyro_rate)
    if initial_bias_B is not None:
        gyro_p = dataclasses.replace(gyro_p, initial_bias_B=initial_bias_B)
    star_p = dataclasses.replace(prof.star_tracker, rate=1.0 / dt)
    h = 1.0 / max(gyro_p.rate, star_p.rate)
    n_truth = int(round((n - 1) * dt / h)) + 1
    t = np.arange(n_truth) * h
    w = np.asarray(omega_B, dtype=float)[:, None]
    q = rot.box_plus(np.repeat(rot.normalize(np.asarray(q0))[:, None], n_truth, axis=1), w * t)
    rng = np.random.default_rng(seed)
    gyro = measure_gyro(gyro_p, t, np.repeat(w, n_truth, axis=1), rng=rng)
    star = measure_star_tracker(star_p, t, q, rng=rng)
    tuning = MEKFTuning(gyro_p.sigma_v, gyro_p.sigma_u, star_p.covariance(), **tuning_kw)
    return SpinCase(t, q, gyro, star, tuning, prof)


@pytest.fixture
def spin_case():
    """Factory fixture: ``spin_case(n, seed=...)`` -> :class:`SpinCase`."""
    return make_spin_case
