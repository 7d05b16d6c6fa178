"""Mode classification, centreline sampling and rigid-body vectors, on synthetic fields and the strip."""

import numpy as np
import pytest
from panel_cases import euler_bernoulli_shape

from postcapture.core.errors import PanelModelError
from postcapture.panels import PanelGeometry, PanelModes, panel_mesh, solve_modes
from postcapture.panels.modes import classify_modes, nodal_areas, rigid_body_vectors


@pytest.fixture(scope="module")
def mesh():
    return panel_mesh(PanelGeometry(3.0, 1.0), n_length=6, n_width=4)


def synthetic_shapes(mesh):
    """Hand-made fields: bending (w = x^2), torsion (w = x y), in-plane (v = x^2), chordwise (w = x y^2)."""
    x, y, _ = mesh.nodes.T
    s = np.zeros((mesh.n_nodes, 6, 4))
    s[:, 2, 0] = x**2
    s[:, 2, 1] = x * y
    s[:, 1, 2] = x**2
    s[:, 2, 2] = 0.01 * x**2
    s[:, 2, 3] = x * y**2
    return s


def test_classification_of_synthetic_fields(mesh):
    assert classify_modes(mesh, synthetic_shapes(mesh)) == ("bending", "torsion", "in-plane", "bending")


def test_nodal_areas_sum_to_the_planform(mesh):
    assert nodal_areas(mesh).sum() == pytest.approx(3.0)
    # corner nodes carry a quarter of one element, interior nodes a whole element
    assert nodal_areas(mesh)[0] == pytest.approx(0.5 * 0.25 / 4)


def test_rigid_body_vectors_are_rigid(mesh):
    r = rigid_body_vectors(mesh).reshape(mesh.n_nodes, 6, 6)
    omega = np.array([0.3, -0.2, 0.5])
    disp = r[:, :3, 3:] @ omega  # displacement field of a small rotation about the origin
    np.testing.assert_allclose(disp, np.cross(omega, mesh.nodes), atol=1e-15)
    np.testing.assert_allclose(r[:, 3:, 3:] @ omega, np.tile(omega, (mesh.n_nodes, 1)))


def test_centreline_matches_the_closed_form_cantilever_shapes(strip):
    modes = solve_modes(strip.geometry, strip.laminate, n_length=40, n_width=2, n_modes=4)
    stations = np.linspace(0.0, strip.length, 11)  # e.g. the joints of a 10-segment chain
    idx = modes.indices("bending")[:2]
    w, slope = modes.centreline(stations, idx)
    for k, mode in enumerate((1, 2)):
        phi, dphi = euler_bernoulli_shape(stations, strip.length, mode)
        scale = w[-1, k]
        np.testing.assert_allclose(w[:, k] / scale, phi, atol=2e-3)
        np.testing.assert_allclose(slope[:, k] / scale, dphi, atol=2e-2 * np.max(np.abs(dphi)))
    # between nodes the Hermite interpolation is smooth: a station off the node grid is consistent
    w_mid, _ = modes.centreline([0.5 * strip.length + 0.0125], idx[:1])
    phi_mid, _ = euler_bernoulli_shape(np.array([0.5125]), strip.length, 1)
    assert w_mid[0, 0] / w[-1, 0] == pytest.approx(phi_mid[0], abs=2e-3)


def test_centreline_with_an_odd_number_of_elements_across(strip):
    even = solve_modes(strip.geometry, strip.laminate, n_length=20, n_width=2, n_modes=2)
    odd = solve_modes(strip.geometry, strip.laminate, n_length=20, n_width=3, n_modes=2)
    s = np.array([0.25, 1.0])
    w_even, _ = even.centreline(s, [0])
    w_odd, _ = odd.centreline(s, [0])
    np.testing.assert_allclose(np.abs(w_odd), np.abs(w_even), rtol=1e-3)


def test_bad_queries(strip):
    modes = solve_modes(strip.geometry, strip.laminate, n_length=10, n_width=2, n_modes=3)
    with pytest.raises(PanelModelError, match=r"stations: expected values in \[0, 1\] m"):
        modes.centreline([0.5, 1.5])
    with pytest.raises(PanelModelError, match="kind: expected one of bending, torsion, in-plane"):
        modes.indices("flapping")
    with pytest.raises(PanelModelError, match="bending mode 9: expected computed"):
        modes.frequency("bending", 9)


def test_modes_without_participation_have_no_effective_mass(mesh):
    modes = PanelModes(mesh=mesh, frequencies_hz=np.arange(1.0, 5.0), shapes=synthetic_shapes(mesh))
    assert modes.kinds[1] == "torsion"
    with pytest.raises(PanelModelError, match="effective_mass: expected modes from solve_modes"):
        _ = modes.effective_mass
