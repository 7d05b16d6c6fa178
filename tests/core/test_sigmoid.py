"""The constrained-parameter sigmoid map against its closed forms."""

import numpy as np
import pytest

from postcapture.core.errors import DomainError, ScenarioError
from postcapture.core.sigmoid import SigmoidMap


def test_defaults_are_the_reference_values():
    m = SigmoidMap()
    assert (m.a, m.b, m.c) == (9000.0, 5000.0, 0.001)


def test_forward_closed_form_and_limits():
    m = SigmoidMap()
    x = np.array([-3000.0, -500.0, 0.0, 250.0, 4000.0])
    expected = m.b + (m.a - m.b) / (1.0 + np.exp(-m.c * x))
    assert np.allclose(m.forward(x), expected, rtol=1e-15)
    assert m.forward(0.0) == pytest.approx(7000.0)
    assert m.b < m.forward(-1e4) < m.b + 1.0 and m.a - 1.0 < m.forward(1e4) < m.a
    assert m.forward(-1e6) >= m.b and m.forward(1e6) <= m.a  # saturates in floating point, never beyond
    assert np.all(np.diff(m.forward(np.linspace(-1e4, 1e4, 101))) >= 0)


def test_inverse_closed_form_and_round_trip():
    m = SigmoidMap()
    theta = np.array([5000.5, 6000.0, 7827.9, 8999.0])
    assert np.allclose(m.inverse(theta), -(1.0 / m.c) * np.log((m.a - theta) / (theta - m.b)), rtol=1e-12)
    assert np.allclose(m.forward(m.inverse(theta)), theta, rtol=1e-13)
    x = np.linspace(-5000.0, 5000.0, 41)
    assert np.allclose(m.inverse(m.forward(x)), x, atol=1e-8)


@pytest.mark.parametrize("params", [{}, {"a": 10.0, "b": -2.0, "c": 3.0}])
def test_derivative_against_finite_differences_and_closed_form(params):
    m = SigmoidMap(**params)
    x = np.linspace(-4.0, 4.0, 17) / m.c
    h = 1e-4 / m.c
    fd = (m.forward(x + h) - m.forward(x - h)) / (2 * h)
    assert np.allclose(m.derivative(x), fd, rtol=1e-7)
    theta = m.forward(x)
    assert np.allclose(m.derivative(x), m.c * (theta - m.b) * (m.a - theta) / (m.a - m.b), rtol=1e-12)
    assert m.derivative(0.0) == pytest.approx(m.c * (m.a - m.b) / 4.0, rel=1e-15)


@pytest.mark.parametrize("theta", [5000.0, 9000.0, 4000.0, 12000.0, np.nan])
def test_inverse_outside_the_open_interval_raises(theta):
    with pytest.raises(DomainError, match=r"strictly inside \(b, a\) = \(5000, 9000\)"):
        SigmoidMap().inverse(theta)


def test_invalid_parameters_list_every_problem():
    with pytest.raises(ScenarioError, match="2 problems") as info:
        SigmoidMap(a=1.0, b=2.0, c=0.0)
    text = str(info.value)
    assert "SigmoidMap.a: expected a > b = 2.0" in text and "SigmoidMap.c: expected c > 0" in text
    assert isinstance(info.value, ValueError)
