"""MEKF against closed forms (constant-rate spin, Farrenkopf's bound), consistency and robustness."""

import logging

import numpy as np
import pytest
from scipy.linalg import expm

from postcapture.core import rotations as rot
from postcapture.core.consistency import chi2_bounds, nees
from postcapture.core.errors import FilterDivergenceError, ScenarioError
from postcapture.core.units import ARCSEC, DEG, DEG_PER_HOUR
from postcapture.estimation import MEKF, MEKFTuning, StepFlag, farrenkopf_steady_state, run_mekf
from postcapture.estimation.mekf import error_transition, process_noise

P0_DEFAULT = np.diag([(20 * ARCSEC) ** 2] * 3 + [(0.1 * DEG_PER_HOUR) ** 2] * 3)


@pytest.mark.parametrize("omega", [[0.3, -0.2, 0.5], [1e-7, 2e-7, -1e-7], [0.0, 0.0, 0.0]])
def test_error_transition_is_the_exact_exponential(omega):
    """Phi = expm(A dt) with A = [[-[w x], -I], [0, 0]] (error dynamics at a constant rate)."""
    dt = 0.7
    A = np.zeros((6, 6))
    A[:3, :3] = -rot.skew(omega)
    A[:3, 3:] = -np.eye(3)
    assert np.allclose(error_transition(np.array(omega), dt), expm(A * dt), atol=1e-13, rtol=1e-12)


def test_constant_rate_spin_converges(spin_case):
    """From 0.5 deg and 0.2 deg/h errors the estimate converges to the closed-form truth."""
    case = spin_case(1501, seed=61, omega_B=(0.01, -0.02, 0.03))
    P0 = np.diag([(0.5 * DEG) ** 2] * 3 + [(0.3 * DEG_PER_HOUR) ** 2] * 3)
    q0 = rot.box_plus(case.q_BN[:, 0], np.array([0.3, -0.3, 0.2]) * DEG)
    hist = run_mekf(case.star.t, case.gyro, case.star, case.tuning, q0, P0)
    assert hist.success and hist.counts["updates"] == 1501 and hist.counts["rejected"] == 0
    q_true = case.q_BN[:, np.searchsorted(case.t, case.star.t)]
    err = hist.attitude_error(q_true)
    assert np.max(np.abs(err[:, 0])) < 60 * ARCSEC  # first update: from 0.5 deg to star-tracker level
    late = slice(750, None)
    assert np.max(np.abs(err[:, late]) / hist.sigmas[:3, late]) < 4.5
    assert np.all(hist.sigmas[:3, -1] < 1.0 * ARCSEC)
    k = np.searchsorted(case.gyro.t, case.star.t)
    bias_err = case.gyro.truth["bias_B"][:, k] - hist.states["gyro_bias_B"]
    assert np.all(np.abs(bias_err[:, -1]) < 0.5 * np.abs(bias_err[:, 0]))
    assert np.all(np.abs(bias_err[:, -1]) < 3.0 * hist.sigmas[3:, -1])


def test_steady_state_error_matches_farrenkopf_cross_boresight(spin_case):
    r"""Cross-boresight steady-state attitude error within 20 % of Farrenkopf's bound.

    Farrenkopf (J. Guidance and Control 1(4), 1978; Markley & Crassidis 2014, sec. 6.4): per axis, with
    :math:`S_v = \sigma_v\sqrt{dt}/\sigma_n`, :math:`S_u = \sigma_u dt^{3/2}/\sigma_n`,
    :math:`\gamma = (S_u + \sqrt{16 + 4 S_v^2 + S_u^2/3})/4`, :math:`\xi = \gamma + \sqrt{\gamma^2 - 1}`,
    the post-update attitude variance is :math:`\sigma_n^2 (1 - \xi^{-2})` (implemented in
    ``postcapture.core.farrenkopf`` and checked against the discrete Riccati equation there).

    Realistic profile (2 arcsec cross, 10 arcsec roll, ARW 0.002 deg/sqrt(h), bias walk from 0.01 deg/h),
    dt = 0.1 s, spin about the boresight so that the two cross axes mix but never meet the roll axis.
    Started at the steady state (covariance from the closed form), 6000 samples.
    """
    case = spin_case(6001, seed=62, omega_B=(0.0, 0.0, 1.0 * DEG))
    p = case.profile
    dt = 0.1
    f_cross = farrenkopf_steady_state(p.star_tracker.sigma_cross, p.gyro.sigma_v, p.gyro.sigma_u, dt)
    f_roll = farrenkopf_steady_state(p.star_tracker.sigma_roll, p.gyro.sigma_v, p.gyro.sigma_u, dt)
    P0 = np.diag([f_cross.attitude_post**2] * 2 + [f_roll.attitude_post**2] + [f_cross.bias_post**2] * 3)
    rng = np.random.default_rng(620)
    q0 = rot.box_plus(case.q_BN[:, 0], np.sqrt(np.diag(P0)[:3]) * rng.standard_normal(3))
    b0 = case.gyro.truth["bias_B"][:, 0] - np.sqrt(np.diag(P0)[3:]) * rng.standard_normal(3)
    hist = run_mekf(case.star.t, case.gyro, case.star, case.tuning, q0, P0, bias0_B=b0)
    err = hist.attitude_error(case.q_BN[:, np.searchsorted(case.t, case.star.t)])[:, 500:]
    # the filter's own covariance settles on the closed form (a deterministic check of the recursion)
    assert hist.sigmas[0, -1] == pytest.approx(f_cross.attitude_post, rel=0.01)
    assert hist.sigmas[2, -1] == pytest.approx(f_roll.attitude_post, rel=0.01)
    sigma_cross = np.sqrt(np.mean(err[:2] ** 2))
    assert sigma_cross / f_cross.attitude_post == pytest.approx(1.0, abs=0.2)


def test_mean_nees_over_50_seeds_is_inside_the_95_percent_band(spin_case):
    """Initial errors drawn from P0; run-averaged NEES (N = 50) at every instant, attitude (3), full (6)."""
    n_runs, n_steps = 50, 100
    nees3, nees6 = [], []
    for seed in range(n_runs):
        case = spin_case(n_steps, seed=1000 + seed, omega_B=(0.01, -0.02, 0.03))
        rng = np.random.default_rng(5000 + seed)
        d0 = np.sqrt(np.diag(P0_DEFAULT)) * rng.standard_normal(6)
        q0 = rot.box_plus(case.q_BN[:, 0], -d0[:3])  # truth = box_plus(estimate, d0[:3]) to first order
        b0 = case.gyro.truth["bias_B"][:, 0] - d0[3:]
        hist = run_mekf(case.star.t, case.gyro, case.star, case.tuning, q0, P0_DEFAULT, bias0_B=b0)
        e_att = hist.attitude_error(case.q_BN)
        e_bias = case.gyro.truth["bias_B"] - hist.states["gyro_bias_B"]
        nees3.append(hist.nees(e_att))
        nees6.append(nees(np.vstack([e_att, e_bias]), hist.P))
    for dim, values in ((3, np.mean(nees3, axis=0)), (6, np.mean(nees6, axis=0))):
        lo, hi = chi2_bounds(dim, n_runs)
        assert lo < np.mean(values) < hi, (dim, np.mean(values), lo, hi)
        assert lo < values[-1] < hi, (dim, values[-1], lo, hi)
        assert np.mean((values > lo) & (values < hi)) > 0.85


def test_missing_samples_are_skipped_and_counted(spin_case):
    case = spin_case(201, seed=63)
    star_values, star_valid = case.star.values.copy(), case.star.valid.copy()
    star_values[:, [10, 50]] = np.nan  # NaN without the flag, and a flagged dropout
    star_valid[80] = False
    gyro_values = case.gyro.values.copy()
    gyro_values[:, 30] = np.nan
    star = type(case.star)("star_tracker", case.star.t, star_values, star_valid, "-", 10.0)
    gyro = type(case.gyro)("gyro", case.gyro.t, gyro_values, case.gyro.valid, "rad/s", 10.0)
    hist = run_mekf(case.star.t, gyro, star, case.tuning, case.q_BN[:, 0], P0_DEFAULT)
    assert hist.success
    assert hist.counts["measurements_missing"] == 3 and hist.counts["inputs_missing"] == 1
    assert hist.counts["updates"] == 201 - 3
    assert list(np.flatnonzero(hist.flagged(StepFlag.MEASUREMENT_MISSING))) == [10, 50, 80]
    assert list(np.flatnonzero(hist.flagged(StepFlag.INPUT_MISSING))) == [31]
    assert np.all(np.isfinite(hist.q_BN)) and np.isnan(hist.nis[10]) and np.isfinite(hist.nis[11])


def test_100_sigma_outlier_is_gated_out_and_logged(spin_case, caplog):
    case = spin_case(201, seed=64)
    values = case.star.values.copy()
    sigma = np.sqrt(np.diag(case.tuning.star_covariance))
    values[:, 120] = rot.box_plus(values[:, 120], 100 * sigma * np.array([1.0, 0.0, 0.0]))
    star = type(case.star)("star_tracker", case.star.t, values, case.star.valid, "-", 10.0)
    with caplog.at_level(logging.INFO, logger="postcapture.estimation.filter"):
        hist = run_mekf(case.star.t, case.gyro, star, case.tuning, case.q_BN[:, 0], P0_DEFAULT)
    assert hist.counts["rejected"] == 1 and list(np.flatnonzero(hist.flagged(StepFlag.REJECTED))) == [120]
    assert hist.nis[120] > 1e3 and hist.counts["recoveries"] == 0
    assert any("star_tracker sample at t = 12 s rejected" in r.getMessage() for r in caplog.records)
    err = hist.attitude_error(case.q_BN[:, np.searchsorted(case.t, case.star.t)])
    assert np.max(np.abs(err[:, 115:125]) / hist.sigmas[:3, 115:125]) < 5.0  # the outlier left no trace
    # without the gate the same outlier drags the estimate away
    ungated = MEKFTuning(case.tuning.sigma_v, case.tuning.sigma_u, case.tuning.star_covariance,
                         gate_probability=None)
    bad = run_mekf(case.star.t, case.gyro, star, ungated, case.q_BN[:, 0], P0_DEFAULT)
    bad_err = bad.attitude_error(case.q_BN[:, np.searchsorted(case.t, case.star.t)])
    assert np.abs(bad_err[0, 120]) > 5 * hist.sigmas[0, 120] and np.abs(err[0, 120]) < 4 * hist.sigmas[0, 120]


def test_a_filter_that_cannot_recover_diverges_reinitialises_and_goes_on(spin_case):
    """An unmodelled 0.5 deg/s gyro bias, with the filter sure of its zero bias: the star-tracker samples are
    gated, the recoveries cannot widen the covariance fast enough, divergence is declared (time, cause),
    the filter re-acquires from the star tracker and the run goes on; raise_on_divergence reports it."""
    case = spin_case(601, seed=65, initial_bias_B=[0.5 * DEG, 0.0, 0.0], name="mekf_test")
    P0 = np.diag([(20 * ARCSEC) ** 2] * 3 + [1e-30] * 3)
    with pytest.raises(FilterDivergenceError, match=r"filter 'mekf_test' diverged at t = \d") as info:
        run_mekf(case.star.t, case.gyro, case.star, case.tuning, case.q_BN[:, 0], P0)
    err = info.value
    assert err.filter_name == "mekf_test" and 0.0 < err.time <= 10.0 and "recoveries" in err.cause
    assert isinstance(err, RuntimeError)
    hist = run_mekf(case.star.t, case.gyro, case.star, case.tuning, case.q_BN[:, 0], P0, raise_on_divergence=False)
    assert not hist.success and hist.status == -1 and "diverged" in hist.message
    kinds = [e.kind for e in hist.events]
    assert kinds[0] == "recovering" and "in a row rejected by the gate" in hist.events[0].cause
    assert "diverged" in kinds and kinds[kinds.index("diverged") + 1] == "reinitialised"
    k = int(np.argmax(hist.flagged(StepFlag.DIVERGED)))
    assert hist.t[k] == pytest.approx(err.time, abs=0.1)
    e = hist.attitude_error(case.q_BN[:, np.searchsorted(case.t, case.star.t)])
    assert np.all(np.isfinite(hist.q_BN)) and np.all(np.abs(e[:, -300:]) <= 3.5 * hist.sigmas[:3, -300:])


def test_a_gyro_bias_step_is_recovered_and_the_filter_stays_consistent(spin_case):
    """A 1 deg/h bias step at 60 s: the filter bumps its bias covariance and is consistent before and after."""
    case = spin_case(1801, seed=67)
    step = 1.0 * DEG_PER_HOUR
    gyro_values = case.gyro.values.copy()
    gyro_values[0, case.gyro.t >= 60.0] += step
    gyro = type(case.gyro)("gyro", case.gyro.t, gyro_values, case.gyro.valid, "rad/s", case.gyro.rate)
    hist = run_mekf(case.star.t, gyro, case.star, case.tuning, case.q_BN[:, 0], P0_DEFAULT)
    assert hist.success  # recovered, not diverged
    assert any(e.kind == "recovering" and e.t > 60.0 for e in hist.events)
    e = hist.attitude_error(case.q_BN[:, np.searchsorted(case.t, case.star.t)])
    z = (e / hist.sigmas[:3]) ** 2
    before = np.mean(np.sum(z[:, 100:600], axis=0))
    after = np.mean(np.sum(z[:, 1200:], axis=0))
    assert before < 4.5 and after < 4.5, (before, after)  # time-averaged NEES of 3 dof near 3
    b = (case.gyro.truth["bias_B"][0, -1] + step) - hist.states["gyro_bias_B"][0, -1]
    assert abs(b) < 3 * hist.sigmas[3, -1]


def test_stepper_divergence_on_an_indefinite_covariance_and_lifecycle():
    tuning = MEKFTuning(1e-6, 1e-9, 1e-10 * np.eye(3))
    f = MEKF(tuning, rot.IDENTITY, 1e-8 * np.eye(6), t0=5.0)
    f.predict(5.0, 0.1, np.zeros(3))
    from postcapture.estimation.filter import FilterStatus, Measurement

    assert f.update(Measurement("star_tracker", 5.1, rot.IDENTITY, -1.0 * np.eye(3))) is None
    assert f.events[0].kind == "diverged" and f.events[0].t == 5.1 and "innovation covariance" in f.events[0].cause
    assert f.status is FilterStatus.RECOVERING  # re-initialised: it goes on
    f.predict(5.1, 0.1, np.zeros(3))
    res = f.update(Measurement("star_tracker", 5.2, rot.IDENTITY, tuning.star_covariance))
    assert res.accepted and f.diverged_at == 5.1
    with pytest.raises(ScenarioError, match="MEKF.P0: expected a positive definite"):
        MEKF(tuning, rot.IDENTITY, -np.eye(6))


def test_tuning_validation_lists_every_problem():
    with pytest.raises(ScenarioError, match="3 problems") as info:
        MEKFTuning(-1.0, 1e-9, np.ones((2, 2)), gate_probability=1.5)
    text = str(info.value)
    assert "MEKFTuning.sigma_v" in text and "star_covariance" in text and "gate_probability" in text


def test_fast_gyro_and_offset_star_samples(spin_case):
    """A 50 Hz gyro with a 10 Hz star tracker; output on the gyro grid, updates flagged on star instants."""
    case = spin_case(301, seed=66, gyro_rate=50.0, omega_B=(0.01, 0.02, -0.01))
    hist = run_mekf(case.gyro.t, case.gyro, case.star, case.tuning, case.q_BN[:, 0], P0_DEFAULT)
    assert hist.success and hist.counts["updates"] == 301
    assert np.allclose(hist.t[hist.flagged(StepFlag.UPDATED)], case.star.t)
    err = hist.attitude_error(case.q_BN[:, np.searchsorted(case.t, case.gyro.t)])
    assert np.max(np.abs(err[:, 500:]) / hist.sigmas[:3, 500:]) < 4.5


def test_process_noise_is_the_van_loan_discretisation():
    """At zero rate, Q equals the exact discretisation of d(dtheta)/dt = -db - eta_v, d(db)/dt = eta_u."""
    sigma_v, sigma_u, dt = 3e-4, 2e-5, 0.5
    A = np.zeros((6, 6))
    A[:3, 3:] = -np.eye(3)
    G = np.diag([-1.0] * 3 + [1.0] * 3)
    Qc = np.diag([sigma_v**2] * 3 + [sigma_u**2] * 3)
    C = expm(np.block([[-A, G @ Qc @ G.T], [np.zeros((6, 6)), A.T]]) * dt)
    Phi = C[6:, 6:].T
    assert np.allclose(Phi @ C[:6, 6:], process_noise(sigma_v, sigma_u, dt), rtol=1e-10, atol=1e-20)
