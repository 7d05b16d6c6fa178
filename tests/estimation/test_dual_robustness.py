"""Dual and joint schemes: missing samples, outliers, divergence."""

import dataclasses
import logging

import numpy as np
import pytest

from postcapture.studies.cases import CASES, dual_config
from postcapture.studies.main_job import initial_state_and_sensitivity
from postcapture.studies.sensing import measure_all, resolve_profile
from postcapture.studies.tuning import resolve_tuning
from postcapture.core import rotations as rot
from postcapture.core.errors import FilterDivergenceError
from postcapture.dynamics.build import build_system
from postcapture.dynamics.process_model import NativeProcessModel
from postcapture.dynamics.simulate import simulate
from postcapture.estimation.dual import run_dual
from postcapture.estimation.filter import RecoveryPolicy
from postcapture.estimation.history import StepFlag


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
    m = NativeProcessModel(build_system(sc), sc.estimation.model_step, sc.estimation.integrator)
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
    assert any("star_tracker sample at t = 8 s rejected" in r.getMessage() for r in caplog.records)
    err = np.linalg.norm(rot.box_minus(truth["q_BN"][:, 81], res.attitude.q_BN[:, 81]))
    assert err < 10 * sigma  # the outlier did not move the estimate


def test_a_burst_of_bad_samples_is_recovered_not_a_stop(setup):
    """Two seconds of star-tracker samples 0.3 rad off: the MEKF gates them, recovers, and is consistent after.

    The MEKF, not the reference's attitude EKF: against the converged truth that EKF is not consistent even
    without the burst (its error reaches 17 of its sigmas at 20 s), so it could not show a recovery."""
    sc, truth, profile, sensors = setup
    star = sensors.star.values.copy()
    bad = slice(100, 120)
    star[:, bad] = rot.box_plus(star[:, bad], np.array([0.3, 0.0, 0.0])[:, None] * np.ones((1, 20)))
    m, x0, S0 = _model(sc, sc.target.mass)
    cfg = _dual(sc, "mekf_flexible", profile, sc.target.mass)
    res = run_dual(m, _with_star(sensors, star), cfg, x0=x0, theta0=sc.target.mass, t_grid=truth.t, S0=S0,
                   q0_BN=truth["q_BN"][:, 0])
    events = res.attitude.events
    assert events and events[0].kind == "recovering" and 10.0 <= events[0].t < 11.0
    assert "in a row rejected by the gate" in events[0].cause
    assert res.attitude.success and np.all(np.isfinite(res.attitude.q_BN))
    err = res.attitude.attitude_error(truth["q_BN"])
    assert np.all(np.abs(err[:, -20:]) <= 3.0 * res.attitude.sigmas[:3, -20:])


def test_divergence_names_filter_time_and_cause_and_the_run_goes_on(setup):
    """A star tracker that turns 0.3 rad off for good (a misalignment the model cannot follow): divergence."""
    sc, truth, profile, sensors = setup
    star = sensors.star.values.copy()
    star[:, 100:] = rot.box_plus(star[:, 100:], np.array([0.3, 0.0, 0.0])[:, None] * np.ones(star[:, 100:].shape[1]))
    m, x0, S0 = _model(sc, sc.target.mass)
    cfg = _dual(sc, "ekf_flexible", profile, sc.target.mass)
    strict = dataclasses.replace(cfg.ekf, recovery=RecoveryPolicy(max_recoveries=0))
    cfg = dataclasses.replace(cfg, ekf=strict)
    with pytest.raises(FilterDivergenceError, match=r"ekf_flexible/ekf. diverged at t = 10\.4 s: 1 recoveries within"):
        run_dual(m, _with_star(sensors, star), cfg, x0=x0, theta0=sc.target.mass, t_grid=truth.t, S0=S0,
                 q0_BN=truth["q_BN"][:, 0])
    res = run_dual(m, _with_star(sensors, star), cfg, x0=x0, theta0=sc.target.mass, t_grid=truth.t, S0=S0,
                   q0_BN=truth["q_BN"][:, 0], raise_on_divergence=False)
    assert not res.attitude.success and res.attitude.status == -1 and "diverged" in res.attitude.message
    assert res.attitude.flagged(StepFlag.DIVERGED)[-1] and np.all(np.isfinite(res.mass))


def test_the_callers_model_is_never_changed(setup):
    sc, truth, profile, sensors = setup
    m, x0, S0 = _model(sc, sc.target.mass - 100.0)
    before = m.mass
    run_dual(m, sensors, _dual(sc, "ekf_flexible", profile, sc.target.mass - 100.0), x0=x0,
             theta0=sc.target.mass - 100.0, t_grid=truth.t, S0=S0, q0_BN=truth["q_BN"][:, 0])
    assert m.mass == before
