"""The linearised panel chain: Euler-Bernoulli limit, closed-form torsion, sampling conventions."""

import numpy as np
import pytest
from panel_cases import BETA_L

from postcapture.config.flexibility import stiffness_from_ei
from postcapture.core.errors import PanelModelError
from postcapture.dynamics.assembly import assemble_panel_chain
from postcapture.dynamics.modes import structural_modes
from postcapture.dynamics.system import System
from postcapture.panels import LumpedChain, chain_panel, lumped_modes
from postcapture.panels.lumped import centreline_maps

L, W, M, EI, KT = 14.0, 5.0, 336.0, 18870.0, 1200.0


def uniform_panel(n, ei=EI):
    k = stiffness_from_ei([0.0, L], [ei], L, n)
    return chain_panel("wing", length=L, width=W, mass=M, bending_stiffness=k, torsion_stiffness=KT)


def euler_bernoulli_hz(mode=1):
    return BETA_L[mode - 1] ** 2 / (2 * np.pi) * np.sqrt(EI / (M / L * L**4))


def test_uniform_chain_first_bending_frequency_tends_to_euler_bernoulli_with_order_two():
    ns = np.array([5, 10, 20, 40])
    f_eb = euler_bernoulli_hz()
    err = np.array([lumped_modes(uniform_panel(n)).frequency("bending") / f_eb - 1 for n in ns])
    assert np.all(err < 0) and np.all(np.diff(np.abs(err)) < 0)  # from below, monotonically
    order = -np.polyfit(np.log(ns), np.log(np.abs(err)), 1)[0]
    assert order == pytest.approx(2.0, abs=0.05)
    assert abs(err[0]) < 0.02 and abs(err[-1]) < 3e-4  # N = 5: -1.8 %; N = 40: about -0.03 %


def test_second_and_third_bending_modes_converge_too():
    modes = lumped_modes(uniform_panel(40))
    for r in (2, 3):
        assert modes.frequency("bending", r) == pytest.approx(euler_bernoulli_hz(r), rel=5e-3)


def test_torsion_mode_is_the_closed_form_hinge_on_a_thin_plate():
    """One hinge about the panel axis carrying a thin plate: f = sqrt(k / (m w^2 / 12)) / (2 pi)."""
    modes = lumped_modes(uniform_panel(5))
    assert modes.indices("torsion").size == 1
    f = np.sqrt(KT / (M * W**2 / 12)) / (2 * np.pi)
    assert modes.frequency("torsion") == pytest.approx(f, rel=1e-12)
    assert LumpedChain(uniform_panel(5)).torsion_inertia == pytest.approx(M * W**2 / 12, rel=1e-12)


def test_fast_bending_eigensolution_is_the_simulated_models():
    panel = uniform_panel(6)
    chain = LumpedChain(panel)
    k = np.linspace(3e4, 5e3, 6)
    omega2, phi = chain.bending_eigen(k)
    ref = lumped_modes(chain.with_stiffness(k))
    f_ref = ref.frequencies_hz[ref.indices("bending")]
    np.testing.assert_allclose(np.sqrt(omega2) / (2 * np.pi), f_ref, rtol=1e-10)
    sysm = System(assemble_panel_chain(chain.with_stiffness(k)))
    np.testing.assert_allclose(chain.stiffness_matrix(k, KT), sysm.K_e, rtol=1e-14)
    m_bb = chain.mass_matrix[np.ix_(chain.bending_index, chain.bending_index)]
    np.testing.assert_allclose(phi.T @ m_bb @ phi, np.eye(6), atol=1e-12)
    assert len(structural_modes(sysm)) == 7


def test_shapes_are_mass_normalised_and_signed_like_the_fem():
    panel = uniform_panel(5)
    modes = lumped_modes(panel)
    chain = LumpedChain(panel)
    np.testing.assert_allclose(modes.shapes.T @ chain.mass_matrix @ modes.shapes, np.eye(6), atol=1e-12)
    w, _ = modes.centreline(modes=modes.indices("bending"))
    assert np.all(w[np.argmax(np.abs(w), axis=0), np.arange(w.shape[1])] > 0)
    assert modes.shapes[modes.torsion_index, modes.indices("torsion")[0]] > 0


def test_centreline_kinematics_of_single_hinge_rotations():
    """theta about +y at hinge j: w = -theta (s - s_j) outboard, slope -theta; the mean at the hinge."""
    n = 4
    s = np.array([0.0, 3.5, 7.0, 10.0, 14.0])
    w_map, slope_map = centreline_maps(L, n, s)
    np.testing.assert_allclose(w_map[:, 0], -s)
    np.testing.assert_allclose(w_map[:, 2], -np.clip(s - 7.0, 0, None))
    np.testing.assert_allclose(slope_map[:, 2], [0.0, 0.0, -0.5, -1.0, -1.0])
    np.testing.assert_allclose(slope_map[:, 0], [-0.5, -1.0, -1.0, -1.0, -1.0])


def test_lumped_mode_queries_and_errors():
    modes = lumped_modes(uniform_panel(3))
    assert modes.n_modes == 4 and modes.kinds.count("bending") == 3
    np.testing.assert_allclose(modes.joint_stations, [L / 3, 2 * L / 3, L])
    np.testing.assert_allclose(modes.midpoints, [L / 6, L / 2, 5 * L / 6])
    with pytest.raises(PanelModelError, match="kind: expected one of bending, torsion"):
        modes.indices("in-plane")
    with pytest.raises(PanelModelError, match="bending mode 4: expected at most 3"):
        modes.frequency("bending", 4)
    with pytest.raises(PanelModelError, match=r"stations: expected values in \[0, 14\] m"):
        modes.centreline([15.0])
    with pytest.raises(PanelModelError, match="mass"):
        chain_panel("bad", length=L, width=W, mass=-1.0, bending_stiffness=[1.0], torsion_stiffness=1.0)
    with pytest.raises(PanelModelError, match="bending_stiffness"):
        chain_panel("bad", length=L, width=W, mass=1.0, bending_stiffness=[1.0, -2.0], torsion_stiffness=1.0)


def test_uniform_moment_gives_the_beam_deflection_at_hinges_and_slope_at_midpoints():
    """Hinge cells of config.flexibility under a uniform bending moment M0 about +y: theta_j = M0 / k_j.

    The beam bends to w = -M0 s^2 / (2 EI), slope -M0 s / EI (a positive moment about +y turns +x towards
    -z): the chain has exactly the beam's w at the hinges and its slope at the segment midpoints, which
    is why the identification samples the slopes there.
    """
    n, m0 = 5, 250.0
    k = stiffness_from_ei([0.0, L], [EI], L, n)
    theta = m0 / k
    s_w = L / n * np.arange(1, n + 1)
    s_mid = L / n * (np.arange(n) + 0.5)
    w_map, _ = centreline_maps(L, n, s_w)
    _, slope_map = centreline_maps(L, n, s_mid)
    np.testing.assert_allclose(w_map @ theta, -m0 * s_w**2 / (2 * EI), rtol=1e-12)
    np.testing.assert_allclose(slope_map @ theta, -m0 * s_mid / EI, rtol=1e-12)
