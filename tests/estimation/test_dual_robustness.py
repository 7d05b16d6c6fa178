"""Dual and joint schemes: missing samples, outliers, divergence."""

import dataclasses
import logging

import numpy as np
import pytest

from postcapture.campaign.cases import CASES, dual_config, joint_tuning
from postcapture.campaign.main_job import initial_state_and_sensitivity
from postcapture.campaign.sensing import measure_all, resolve_profile
from postcapture.campaign.tuning import resolve_tuning
from postcapture.core import rotations as rot
from postcapture.core.errors import FilterDivergenceError
from postcapture.dynamics.build import build_system
from postcapture.dynamics.process_model import NativeProcessModel
from postcapture.dynamics.simulate import simulate
from postcapture.estimation.dual import run_dual
from postcapture.estimation.history import StepFlag
from postcapture.estimation.joint import run_joint


@pytest.fixture(scope="module")
def setup(envisat):
    truth = simulate(envisat, duration=20.0)
    profile = resolve_profile(envisat, "realistic")
    sensors = measure_all(truth, profile, np.random.default_rng(3))
    return envisat, truth, profile, sensors


def _dual(sc, case, profile, m0):
    return dual_config(CASES[case], profile, "realistic", resolve_tuning(sc, "realistic", profile, initial_mass=m0),
                       sc.n_arm, m0)


def _model(sc, theta0):
    m = NativeProcessModel(build_system(sc), sc.simulation.step)
    x0, S0 = initial_state_and_sensitivity(m, theta0)
    return m, x0, S0


def _with_star(sensors, values, valid=None):
    star = dataclasses.replace(sensors.star, values=values, valid=sensors.star.valid if valid is None else valid)
    return dataclasses.replace(sensors, star=star)


@pytest.mark.parametrize("attitude", ["ekf", "mekf"])
def test_missing_samples_are_skipped_and_counted(setup, attitude):
    sc, truth, profile, sensors = setup
    star = sensors.star.values.copy()
    star[:, 50] = np.nan
    valid = sensors.star.valid.copy()
    valid[60] = False
    s2 = _with_star(sensors, star, valid)
    m, x0, S0 = _model(sc, sc.target.mass - 100.0)
    cfg = _dual(sc, f"{attitude}_flexible", profile, sc.target.mass - 100.0)
    res = run_dual(m, s2, cfg, x0=x0, theta0=sc.target.mass - 100.0, t_grid=truth.t, S0=S0, q0_BN=truth["q_BN"][:, 0])
    assert res.counts["measurements_missing"] == 2
    assert res.attitude.flagged(StepFlag.MEASUREMENT_MISSING)[[50, 60]].all()
    assert np.all(np.isfinite(res.attitude.q_BN)) and np.all(np.isfinite(res.mass))


def test_star_tracker_outlier_is_gated_and_logged(setup, caplog):
    sc, truth, profile, sensors = setup
    star = sensors.star.values.copy()
    sigma = profile.star_tracker.sigma_cross
    star[:, 80] = rot.box_plus(star[:, 80], np.array([100 * sigma, 0.0, 0.0]))  # a 100-sigma outlier
    m, x0, S0 = _model(sc, sc.target.mass)
    cfg = _dual(sc, "ekf_flexible", profile, sc.target.mass)
    with caplog.at_level(logging.INFO):
        res = run_dual(m, _with_star(sensors, star), cfg, x0=x0, theta0=sc.target.mass, t_grid=truth.t, S0=S0,
                       q0_BN=truth["q_BN"][:, 0])
    assert res.attitude.flagged(StepFlag.REJECTED)[80]
    assert res.counts["rejected"] >= 1
    assert any("rejected" in r.message and "t = 8" in r.message for r in caplog.records)
    err = np.linalg.norm(rot.box_minus(truth["q_BN"][:, 81], res.attitude.q_BN[:, 81]))
    assert err < 10 * sigma  # the outlier did not move the estimate


def test_divergence_names_filter_time_and_cause(setup):
    sc, truth, profile, sensors = setup
    star = sensors.star.values.copy()
    star[:, 100:] = rot.box_plus(star[:, 100:], np.array([0.3, 0.0, 0.0])[:, None] * np.ones(star[:, 100:].shape[1]))
    m, x0, S0 = _model(sc, sc.target.mass)
    cfg = _dual(sc, "ekf_flexible", profile, sc.target.mass)
    with pytest.raises(FilterDivergenceError, match=r"ekf_flexible/ekf. diverged at t = 11\.9 s: 20 star-tracker samples in a row rejected by the gate"):
        run_dual(m, _with_star(sensors, star), cfg, x0=x0, theta0=sc.target.mass, t_grid=truth.t, S0=S0,
                 q0_BN=truth["q_BN"][:, 0])
    m, x0, S0 = _model(sc, sc.target.mass)
    res = run_dual(m, _with_star(sensors, star), cfg, x0=x0, theta0=sc.target.mass, t_grid=truth.t, S0=S0,
                   q0_BN=truth["q_BN"][:, 0], raise_on_divergence=False)
    assert not res.attitude.success and res.attitude.status == -1 and "diverged" in res.attitude.message
    assert res.attitude.flagged(StepFlag.DIVERGED)[-1]


def test_joint_skips_missing_accelerations_and_stays_spd(setup):
    sc, truth, profile, sensors = setup
    acc = sensors.accel.values.copy()
    acc[:, 30:35] = np.nan
    s2 = dataclasses.replace(sensors, accel=dataclasses.replace(sensors.accel, values=acc))
    m, x0, S0 = _model(sc, sc.target.mass - 100.0)
    m0 = sc.target.mass - 100.0
    tuning = joint_tuning(profile, resolve_tuning(sc, "realistic", profile, initial_mass=m0), sc.n_arm, m0)
    res = run_joint(m, s2, tuning, x0=x0, theta0=m0,
                    t_grid=truth.t, S0=S0, q0_BN=truth["q_BN"][:, 0])
    assert np.all(np.isfinite(res.mass))
    for k in range(0, truth.t.size, 20):
        P = res.attitude.P[:, :, k]
        np.testing.assert_allclose(P, P.T, atol=1e-18)
        assert np.linalg.eigvalsh(P).min() > 0
    assert abs(res.mass[-1] - sc.target.mass) < abs(res.mass[0] - sc.target.mass)
