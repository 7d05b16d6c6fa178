"""The mass filter on a rigid body pushed by a known force: the mass from F = m a.

Chaser, one-joint arm and target all lie on the x axis and the thruster pushes along x through the
centre of mass: the locked stack translates with a = F / M, M = m_chaser + m_link + m_target. The
analytic dz/dm must equal -F / M^2, and the filter must find the target mass from noisy accelerometer
samples with the accuracy of least squares.
"""

import numpy as np
import pytest

from postcapture.config import scenario_from_dict
from postcapture.core.sigmoid import SigmoidMap
from postcapture.dynamics.build import build_system
from postcapture.dynamics.process_model import NativeProcessModel
from postcapture.estimation.filter import Measurement
from postcapture.estimation.mass_filter import MassFilter, MassFilterTuning


def accelerations(t, innovation, dz_dm, R):
    """A linearised accelerations measurement, as a dual scheme hands it to its mass filter."""
    return Measurement("accelerations", t, np.asarray(innovation, dtype=float), np.diag(R), H=np.asarray(dz_dm))

F, M_CHASER, M_LINK, M_TARGET = 200.0, 500.0, 10.0, 2000.0


def stack_scenario():
    return scenario_from_dict({
        "name": "collinear_stack",
        "chaser": {"mass": M_CHASER, "inertia": [[100, 0, 0], [0, 120, 0], [0, 0, 120]]},
        "arm": {"base": {"xyz": [1.0, 0, 0]}, "tool": {"xyz": [1.0, 0, 0]},
                "joints": [{"axis": "z", "mass": M_LINK, "com": [0.5, 0, 0],
                            "inertia": [[0.01, 0, 0], [0, 0.9, 0], [0, 0, 0.9]], "stiffness": 1e5}]},
        "target": {"mass": M_TARGET, "inertia": [[500, 0, 0], [0, 800, 0], [0, 0, 800]],
                   "grasp_to_com": {"xyz": [2.0, 0, 0]}},
        "excitation": [{"channel": "force_x", "kind": "step", "amplitude": F}],
        "simulation": {"duration": 10.0, "step": 0.1, "sample_period": 0.1},
    })


@pytest.fixture(scope="module")
def model():
    return NativeProcessModel(build_system(stack_scenario(), "rigid"), 0.1)


def test_acceleration_and_its_mass_derivative_in_closed_form(model):
    x = model.initial_state()
    p = model.predict(x, 0.0, 0.1, jacobians=True)
    M = M_CHASER + M_LINK + M_TARGET
    assert p.z[0] == pytest.approx(F / M, rel=1e-12)
    np.testing.assert_allclose(p.z[1:3], 0.0, atol=1e-12)
    assert p.h[0] == pytest.approx(-F / M**2, rel=1e-9)


def test_first_update_is_a_newton_step(model):
    """With P0 >> R the update is Gauss-Newton: x1 = x0 + (a - a(x0)) / (da/dx)."""
    M_rest = M_CHASER + M_LINK
    smap = SigmoidMap(a=4000.0, b=500.0, c=0.002)
    tuning = MassFilterTuning(R_diag=np.array([1e-14] * 3 + [1.0]), q_start=0.0, q_end=0.0, P0=1e8,
                              sigmoid=smap, sensitivity="partial")
    theta0 = M_TARGET - 300.0
    filt = MassFilter(tuning, theta0, 0.0, 1.0)
    model.mass = theta0
    p = model.predict(model.initial_state(), 0.0, 0.1, jacobians=True)
    a_true = F / (M_rest + M_TARGET)
    filt.update(accelerations(0.1, np.array([a_true, 0, 0, 0]) - p.z, p.h, tuning.R_diag))
    x0 = smap.inverse(theta0)
    slope = -F / (M_rest + theta0) ** 2 * smap.derivative(x0)
    x1 = x0 + (a_true - F / (M_rest + theta0)) / slope
    assert filt.theta == pytest.approx(smap.forward(x1), rel=1e-9)


def test_mass_from_f_equals_ma_with_least_squares_accuracy(model):
    rng = np.random.default_rng(7)
    m_true, M_rest, sigma, n = M_TARGET, M_CHASER + M_LINK, 1e-4, 200
    R = sigma**2
    tuning = MassFilterTuning(R_diag=np.array([R, R, R, 1.0]), q_start=1e-12, q_end=1e-12, P0=500.0**2,
                              sigmoid=SigmoidMap(a=4000.0, b=500.0, c=0.002), sensitivity="partial")
    filt = MassFilter(tuning, m_true - 300.0, 0.0, n * 0.1)
    x = model.initial_state()
    info = 0.0
    for k in range(n):
        filt.predict(k * 0.1)
        model.mass = filt.theta
        p = model.predict(x, k * 0.1, 0.1, jacobians=True)
        z = np.array([F / (M_rest + m_true), 0.0, 0.0, 0.0]) + np.r_[sigma * rng.standard_normal(3), 0.0]
        filt.update(accelerations((k + 1) * 0.1, z - p.z, p.h, tuning.R_diag))
        info += (F / (M_rest + m_true) ** 2) ** 2 / R  # only the x sample carries the mass
    crlb = 1.0 / np.sqrt(info)  # least squares on a(m) = F / (M_rest + m)
    assert filt.sigma == pytest.approx(crlb, rel=0.05)
    assert abs(filt.theta - m_true) < 3.0 * crlb


def test_sigmoid_keeps_the_mass_in_bounds():
    tuning = MassFilterTuning.reference()
    filt = MassFilter(tuning, 7727.9, 0.0, 100.0)
    for _ in range(5):  # absurd innovations push hard; the mass stays inside (b, a)
        filt.predict(0.0)
        filt.update(accelerations(0.0, np.full(10, 1e3), np.full(10, 1.0), tuning.R_diag))
    assert tuning.sigmoid.b < filt.theta < tuning.sigmoid.a
    assert filt.process_noise(0.0) == pytest.approx(20.1) and filt.process_noise(100.0) == pytest.approx(0.1)
