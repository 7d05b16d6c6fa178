"""The pyfe3d shell model against Euler-Bernoulli, its own convergence, and the Envisat design target."""

import time

import numpy as np
import pytest
from panel_cases import BETA_L, Strip, beam_frequency

from postcapture.core.errors import PanelModelError
from postcapture.panels import builtin_panel, solve_modes
from postcapture.panels.fem import assemble, clamped_dofs
from postcapture.panels.mesh import panel_mesh


def test_uniform_strip_matches_euler_bernoulli_within_one_percent(strip):
    """nu = 0: the plate and the beam have the same bending stiffness, so the only differences are the
    discretisation (O(h^2), ~2e-5 at 60 elements) and shear/rotary inertia (O((h/L)^2), ~1e-7)."""
    modes = solve_modes(strip.geometry, strip.laminate, n_length=60, n_width=2, n_modes=6)
    bending = modes.indices("bending")
    for order in (1, 2, 3):
        f_fem = modes.frequencies_hz[bending[order - 1]]
        f_eb = strip.euler_bernoulli_hz(order)
        assert abs(f_fem - f_eb) / f_eb < 1e-2
    assert abs(modes.frequency("bending") / strip.euler_bernoulli_hz(1) - 1) < 1e-3


def test_poisson_strip_lies_between_the_beam_and_plate_bounds():
    """nu = 0.3: a clamped strip bends between the free-anticlastic beam (EI = E b h^3 / 12) and
    cylindrical bending (b D = EI / (1 - nu^2)); a narrow strip sits close to the beam."""
    s = Strip(nu=0.3)
    f = solve_modes(s.geometry, s.laminate, n_length=60, n_width=4, n_modes=3).frequency("bending")
    lower, upper = s.euler_bernoulli_hz(1), s.euler_bernoulli_hz(1, ei=s.ei / (1 - s.nu**2))
    assert lower < f < upper
    assert abs(f - lower) / lower < 1e-2


def test_first_frequency_converges_with_order_two(strip):
    """Bilinear shell elements with a consistent mass: the eigenvalue error is O(h^(2k)) with k = 1
    (Strang and Fix, ch. 6), so the frequency error is O(h^2); the one-point transverse shear avoids
    locking, so the asymptotic rate shows from 4 elements on. The strip is thin enough (L/h = 2000)
    that the beam/plate model difference stays far below the discretisation error."""
    n = np.array([4, 8, 16, 32])
    f_eb = strip.euler_bernoulli_hz(1)
    err = np.array([solve_modes(strip.geometry, strip.laminate, n_length=int(k), n_width=1, n_modes=2)
                    .frequency("bending") / f_eb - 1 for k in n])
    assert np.all(err > 0)  # a conforming-in-w consistent-mass model approaches from above
    assert np.all(np.diff(err) < 0)
    order = np.polyfit(np.log(1.0 / n), np.log(err), 1)[0]
    assert order == pytest.approx(2.0, abs=0.15), order


def test_effective_masses_match_the_euler_bernoulli_cantilever(strip):
    """m_eff/m = (int phi)^2 / (L int phi^2) for the closed-form clamped-free shapes (0.613, 0.188, 0.065)."""
    x = np.linspace(0.0, strip.length, 20001)
    expected = []
    for mode in (1, 2, 3):
        b = BETA_L[mode - 1]
        sig = (np.cosh(b) + np.cos(b)) / (np.sinh(b) + np.sin(b))
        u = b * x / strip.length
        phi = np.cosh(u) - np.cos(u) - sig * (np.sinh(u) - np.sin(u))
        expected.append(np.trapezoid(phi, x) ** 2 / (strip.length * np.trapezoid(phi**2, x)))
    np.testing.assert_allclose(expected, [0.6131, 0.1883, 0.0647], atol=1e-4)  # the textbook values
    modes = solve_modes(strip.geometry, strip.laminate, n_length=60, n_width=2, n_modes=6)
    bending = modes.indices("bending")[:3]
    fraction_of_total = modes.effective_mass[2, bending] / modes.total_mass
    np.testing.assert_allclose(fraction_of_total, expected, rtol=5e-3)
    assert modes.rigid_mass[2] < modes.total_mass  # the root nodes' share is not moved by base motion
    assert np.all(modes.effective_mass_fraction[2] <= 1.0)


def test_mode_shapes_are_mass_normalised_and_the_root_is_clamped(strip):
    mesh = panel_mesh(strip.geometry, n_length=20, n_width=2)
    modes = solve_modes(strip.geometry, strip.laminate, n_length=20, n_width=2, n_modes=5)
    _, m = assemble(mesh, strip.laminate)
    phi = modes.shapes.reshape(-1, modes.n_modes)
    np.testing.assert_allclose(phi.T @ (m @ phi), np.eye(modes.n_modes), atol=1e-8)
    assert np.all(phi[clamped_dofs(mesh)] == 0.0)
    np.testing.assert_allclose(modes.node_coordinates, mesh.nodes)


def test_envisat_first_bending_near_0p08_hz(envisat_modes):
    """Design target 0.080 Hz (the reference's FEM: 0.0799 Hz). Tolerance 2.5 %: the reference's laminate is
    unknown, and this is the spread of 'near 0.08 Hz' that a lumped chain calibrated on it inherits.
    The FEM must also agree with the laminate's equivalent Euler-Bernoulli beam to 1 %."""
    geometry, laminate = builtin_panel("envisat")
    f1 = envisat_modes.frequency("bending")
    assert f1 == pytest.approx(0.080, rel=0.025)
    assert f1 == pytest.approx(beam_frequency(geometry, laminate), rel=0.01)
    # second bending: Euler-Bernoulli ratio (4.694 / 1.875)^2 = 6.267
    assert envisat_modes.frequency("bending", 2) / f1 == pytest.approx((BETA_L[1] / BETA_L[0]) ** 2, rel=0.02)


def test_envisat_classification_finds_bending_and_torsion(envisat_modes):
    kinds = envisat_modes.kinds
    assert kinds[:4] == ("bending", "torsion", "bending", "torsion")
    # bending modes move the panel along z, torsion modes rotate it about x: effective masses agree
    eff = envisat_modes.effective_mass_fraction
    b1, t1 = envisat_modes.indices("bending")[0], envisat_modes.indices("torsion")[0]
    assert eff[2, b1] > 0.5 and eff[2, t1] < 1e-6
    assert eff[3, t1] > 0.5 and eff[3, b1] < 1e-6
    assert envisat_modes.total_mass == pytest.approx(335.832, rel=1e-9)  # 4.7976 kg/m^2 x 70 m^2


def test_chaser_panel():
    geometry, laminate = builtin_panel("chaser")
    modes = solve_modes(geometry, laminate, n_length=30, n_width=10, n_modes=4)
    assert modes.frequency("bending") == pytest.approx(beam_frequency(geometry, laminate), rel=0.01)
    assert modes.frequency("torsion") > modes.frequency("bending")


def test_reference_mesh_solves_in_under_five_seconds():
    geometry, laminate = builtin_panel("envisat")
    t0 = time.perf_counter()
    solve_modes(geometry, laminate, n_length=60, n_width=20, n_modes=10)
    elapsed = time.perf_counter() - t0
    assert elapsed < 5.0, f"20 x 60 modal solve took {elapsed:.2f} s"


def test_lumped_mass_gives_close_frequencies(strip):
    f_c = solve_modes(strip.geometry, strip.laminate, n_length=40, n_width=2, n_modes=2).frequency("bending")
    f_l = solve_modes(strip.geometry, strip.laminate, n_length=40, n_width=2, n_modes=2, lumped_mass=True
                      ).frequency("bending")
    assert f_l == pytest.approx(f_c, rel=5e-3)


@pytest.mark.parametrize("kw, match", [
    ({"n_length": 0}, r"n_length: expected an integer >= 1 \(a mesh needs at least one element\)"),
    ({"n_width": 0}, r"n_width: expected an integer >= 1"),
    ({"n_length": 2.5}, r"n_length: expected an integer >= 1"),
    ({"n_modes": 0}, r"n_modes: expected an integer in \[1, "),
])
def test_bad_mesh_or_mode_count(strip, kw, match):
    with pytest.raises(PanelModelError, match=match):
        solve_modes(strip.geometry, strip.laminate, **kw)
