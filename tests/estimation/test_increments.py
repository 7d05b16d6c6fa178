"""What the inertial sensors output over a cycle, against quadrature of the instantaneous physics and
finite differences; the gyro calibration's sensitivity; the filters' measurement Jacobians."""

import numpy as np
import pytest

from postcapture.core import rotations as rot
from postcapture.core.triad import axis_matrix
from postcapture.estimation.increments import calibration_matrix, calibration_sensitivity
from postcapture.estimation.increments import mean_rate, mean_specific_force


def _state(rng):
    q0 = rot.normalize(rng.standard_normal(4))
    q1 = rot.box_plus(q0, 0.3 * rng.standard_normal(3))
    return q0, q1, *(rng.standard_normal(3) for _ in range(5))


def test_mean_specific_force_is_the_integral_of_the_instantaneous_one():
    """A body spinning at a constant rate while its origin accelerates uniformly in N: integrate the
    instantaneous specific force at the sensor, rotated into the body frame at the start, by Gauss-Legendre
    quadrature (an independent computation of the same increment)."""
    w = np.array([0.03, -0.02, 0.05])  # rad/s, constant in B
    a_N = np.array([0.01, 0.002, -0.004])  # m/s^2, the origin's acceleration in N
    v0_N = np.array([0.2, -0.1, 0.05])
    r = np.array([0.3, 0.1, 0.2])
    q0 = rot.normalize(np.array([0.9, 0.1, -0.3, 0.2]))
    dt = 0.1

    def state(t):  # attitude, origin velocity in B, body rate
        q = rot.box_plus(q0, w * t)
        return q, rot.dcm_from_quat(q) @ (v0_N + a_N * t)

    def specific_force_B0(t):  # f_N of the sensor point, in the body frame at t = 0
        q, _ = state(t)
        C_NB = rot.dcm_from_quat(q).T
        r_N_ddot = C_NB @ np.cross(w, np.cross(w, r))  # rigid rotation at a constant rate
        return rot.dcm_from_quat(q0) @ (a_N + r_N_ddot)

    nodes, weights = np.polynomial.legendre.leggauss(12)
    quad = sum(wk * specific_force_B0(0.5 * dt * (xk + 1)) for xk, wk in zip(nodes, weights)) * 0.5
    (qa, va), (qb, vb) = state(0.0), state(dt)
    f, _ = mean_specific_force(rot.box_minus(qb, qa), va, w, vb, w, r, dt)
    assert np.allclose(f, quad, rtol=0, atol=1e-13)
    z, _, _, phi = mean_rate(qa, qb, dt)
    assert np.allclose(z, w, rtol=0, atol=1e-14) and np.allclose(phi, w * dt, atol=1e-15)


def test_jacobians_agree_with_central_differences():
    rng = np.random.default_rng(1)
    q0, q1, v0, w0, v1, w1, r = _state(rng)
    dt = 0.1

    def f(d):
        a0, a1 = rot.box_plus(q0, d[0:3]), rot.box_plus(q1, d[3:6])
        phi = rot.box_minus(a1, a0)
        z, _ = mean_specific_force(phi, v0 + d[6:9], w0 + d[9:12], v1 + d[12:15], w1 + d[15:18], r, dt)
        return np.concatenate([z, mean_rate(a0, a1, dt)[0]])

    _, J = mean_specific_force(rot.box_minus(q1, q0), v0, w0, v1, w1, r, dt)
    _, H1, H0, _ = mean_rate(q0, q1, dt)
    analytic = np.vstack([np.hstack([J["att0"], J["att1"], J["v0"], J["w0"], J["v1"], J["w1"]]),
                          np.hstack([H0, H1, np.zeros((3, 12))])])
    eps = 1e-6
    numeric = np.column_stack([(f(eps * e) - f(-eps * e)) / (2 * eps) for e in np.eye(18)])
    assert np.allclose(numeric, analytic, rtol=0, atol=1e-8 * np.abs(analytic).max())


def test_calibration_vector_and_matrix_agree_and_its_sensitivity_is_exact():
    rng = np.random.default_rng(2)
    c = 1e-3 * rng.standard_normal(9)
    w = rng.standard_normal(3)
    M = np.zeros((3, 3))
    M[~np.eye(3, dtype=bool)] = c[3:]  # row-major off-diagonal terms
    assert np.array_equal(axis_matrix(c[:3], M), calibration_matrix(c))
    D = calibration_sensitivity(w)
    numeric = np.column_stack([(calibration_matrix(c + 1e-6 * e) @ w - calibration_matrix(c - 1e-6 * e) @ w) / 2e-6
                               for e in np.eye(9)])
    assert np.allclose(D, numeric, atol=1e-10)


@pytest.fixture(scope="module")
def augmented_filter():
    from postcapture.config import load_scenario
    from postcapture.studies.main_job import plan_run
    from postcapture.dynamics.build import build_system
    from postcapture.dynamics.process_model import NativeProcessModel
    from postcapture.studies.robust import build_augmented

    sc = load_scenario("envisat")
    plan = plan_run(sc, profile="realistic", cases=("joint",), duration=10.0)
    plan = plan.__class__(**{**plan.__dict__, "tuning": plan.tuning.__class__(
        **{**plan.tuning.__dict__, "model_noise": 1e-12})})
    model = NativeProcessModel(build_system(sc), sc.estimation.model_step, sc.estimation.integrator)
    filt = build_augmented(plan, model, rot.IDENTITY, name="joint")
    filt.gyro_cal = 1e-4 * np.arange(1, 10)  # a calibration away from zero, so that its columns are tested
    filt.predict(12.0, 0.1)
    return filt


@pytest.mark.parametrize("kind", ["gyro", "accelerometer"])
def test_the_filters_measurement_jacobians_agree_with_central_differences(augmented_filter, kind):
    """Perturb the filter's error state (plant state, clone, biases, calibration) and difference its own
    predicted measurement: the Jacobian it updates with is exact."""
    filt = augmented_filter
    saved = (filt.x.copy(), filt.gyro_bias.copy(), filt.accel_bias.copy(), filt.gyro_cal.copy(), filt.eta.copy(),
             filt._clone)
    def model():
        return filt._measurement_model(kind)

    z0, H = model()

    def predicted(dx):
        filt._apply(dx)
        z = model()[0]
        filt.x, filt.gyro_bias, filt.accel_bias, filt.gyro_cal, filt.eta, filt._clone = (
            saved[0].copy(), saved[1].copy(), saved[2].copy(), saved[3].copy(), saved[4].copy(), saved[5])
        return z

    cols = np.flatnonzero(np.any(H != 0.0, axis=0))
    eps = 1e-7
    for j in cols:
        e = np.zeros(filt.N)
        e[j] = eps
        numeric = (predicted(e) - predicted(-e)) / (2 * eps)
        assert np.allclose(numeric, H[:, j], rtol=1e-5, atol=1e-7 * np.abs(H).max()), (kind, filt.labels[j])
    assert set(cols) >= ({filt.i_bg.start, filt.i_cal.start} if kind == "gyro" else {filt.i_ba.start})
    assert set(cols) >= set(range(filt.i_clone.start, filt.i_clone.start + (3 if kind == "gyro" else 9)))
