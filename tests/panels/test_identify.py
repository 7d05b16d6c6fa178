"""Stiffness identification: analytic Jacobian, closed-loop recovery, torsion in closed form, errors."""

import numpy as np
import pytest

from postcapture.core.errors import PanelModelError
from postcapture.panels import (
    LumpedChain,
    ModalTarget,
    chain_panel,
    identify_stiffness,
    lumped_modes,
    torsion_stiffness,
)
from postcapture.panels.identify import _Problem, initial_stiffness, modal_assurance, shape_vectors

L, W, M = 14.0, 5.0, 336.0
K_TRUE = {5: np.array([8051.0, 47568.0, 15648.0, 6884.0, 8565.0]),  # the reference's table 2
          8: np.array([3.1e4, 1.2e4, 9.0e3, 1.5e4, 7.0e3, 1.1e4, 6.0e3, 8.0e3])}


def chain_with(k, kt=621.6):
    return LumpedChain(chain_panel("wing", length=L, width=W, mass=M, bending_stiffness=k,
                                   torsion_stiffness=kt))


@pytest.mark.parametrize("weight", [0.1, 1.0, 10.0])
def test_analytic_jacobian_matches_central_differences(weight):
    chain = chain_with(K_TRUE[5])
    other = chain_with(K_TRUE[5] * [1.3, 0.8, 1.1, 0.9, 1.2])
    target = ModalTarget.from_lumped_modes(lumped_modes(other.panel))
    problem = _Problem(chain, target, weight)
    p = np.log(K_TRUE[5])
    jac = problem.evaluate(p)["J"]
    h = 1e-6
    num = np.column_stack([(problem.evaluate(p + h * e, False)["e"] - problem.evaluate(p - h * e, False)["e"])
                           / (2 * h) for e in np.eye(5)])
    assert np.max(np.abs(jac - num)) < 1e-7 * np.max(np.abs(jac))


@pytest.mark.parametrize("n, weight", [(5, 0.1), (5, 1.0), (5, 10.0), (8, 0.1)])
def test_closed_loop_recovers_known_stiffnesses(n, weight):
    """The reference is itself a chain with known k: from a perturbed start the fit returns k to 1e-6."""
    k_true = K_TRUE[n]
    target = ModalTarget.from_lumped_modes(lumped_modes(chain_with(k_true).panel), n_bending=3)
    rng = np.random.default_rng(20240611 + n)
    k0 = k_true * np.exp(rng.normal(0.0, 0.3, n))
    fit = identify_stiffness(chain_with(np.ones(n)), target, weight=weight, k0=k0, xtol=1e-12)
    assert fit.converged, fit.message
    np.testing.assert_allclose(fit.k, k_true, rtol=1e-6)
    np.testing.assert_allclose(fit.frequencies_hz, target.bending_hz, rtol=1e-10)
    np.testing.assert_allclose(fit.mac, 1.0, atol=1e-12)
    assert fit.cost < 1e-20 and np.all(np.diff(fit.history) <= 0)


def test_default_start_is_the_uniform_beam_with_the_reference_first_frequency():
    k = initial_stiffness(ModalTarget(L, 40, np.array([0.08]), np.ones((40, 1)), np.ones((40, 1))), M / L)
    f = lumped_modes(chain_with(k).panel).frequency("bending")
    assert f == pytest.approx(0.08, rel=2e-3)  # the 40-segment chain is within 0.03 % of Euler-Bernoulli


def test_torsion_stiffness_is_closed_form_and_puts_the_torsion_mode_on_target():
    chain = chain_with(K_TRUE[5])
    kt = torsion_stiffness(chain, 0.2105)
    assert kt == pytest.approx((2 * np.pi * 0.2105) ** 2 * M * W**2 / 12, rel=1e-12)
    modes = lumped_modes(chain.with_stiffness(torsion_stiffness=kt))
    assert modes.frequency("torsion") == pytest.approx(0.2105, rel=1e-12)


def test_mac_and_shape_vectors():
    rng = np.random.default_rng(7)
    a = rng.normal(size=(10, 3))
    mac = modal_assurance(a, np.column_stack([-2.0 * a[:, 0], a[:, 1], 5.0 * a[:, 2]]))
    np.testing.assert_allclose(np.diag(mac), 1.0, rtol=1e-12)
    assert np.all((mac >= 0) & (mac <= 1 + 1e-12))
    y = shape_vectors(np.ones((4, 2)), np.zeros((4, 2)), L)
    np.testing.assert_allclose(np.linalg.norm(y, axis=0), 1.0)


def test_envisat_fem_fit_with_w_0_1(envisat_modes):
    """Five segments against the 20 x 60 FEM: first frequency within 1 %, MAC >= 0.99."""
    target = ModalTarget.from_panel_modes(envisat_modes, 5)
    fit = identify_stiffness(chain_with(np.ones(5)), target, weight=0.1)
    assert fit.converged
    assert abs(fit.frequencies_hz[0] / target.bending_hz[0] - 1) < 0.01
    assert np.all(fit.mac >= 0.99)


def test_bad_identification_input():
    chain = chain_with(K_TRUE[5])
    target = ModalTarget.from_lumped_modes(lumped_modes(chain.panel))
    with pytest.raises(PanelModelError, match="weight: expected a finite weight > 0"):
        identify_stiffness(chain, target, weight=0.0)
    with pytest.raises(PanelModelError, match="k0: expected 5 finite stiffnesses > 0"):
        identify_stiffness(chain, target, k0=[1.0, 2.0])
    with pytest.raises(PanelModelError, match=r"target.segments: expected 4 \(the chain's\)"):
        identify_stiffness(chain_with(np.ones(4)), target)
    with pytest.raises(PanelModelError, match="torsion_hz: expected a finite frequency > 0"):
        torsion_stiffness(chain, float("nan"))
    with pytest.raises(PanelModelError, match="segments: expected an integer >= 1"):
        ModalTarget.from_lumped_modes(lumped_modes(chain.panel), segments=0)
