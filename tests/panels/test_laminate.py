"""Classical lamination theory against hand-computed closed forms, pyfe3d's own CLT, and bad input."""

import math

import numpy as np
import pytest

from postcapture.core.errors import PanelModelError
from postcapture.panels import Laminate, OrthotropicMaterial, Ply, equivalent_beam

CFRP = OrthotropicMaterial(e1=140e9, e2=9e9, nu12=0.3, g12=5e9, g13=5e9, g23=3e9, rho=1550.0, name="cfrp")


def q_matrix(m):
    """Hand-written plane-stress reduced stiffness (independent of OrthotropicMaterial.reduced_stiffness)."""
    nu21 = m.nu12 * m.e2 / m.e1
    den = 1 - m.nu12 * nu21
    return m.e1 / den, m.e2 / den, m.nu12 * m.e2 / den, m.g12


def test_single_isotropic_layer_matches_plate_closed_forms():
    e, nu, t = 70e9, 0.33, 2e-3
    lam = Laminate((Ply(t, 17.0, OrthotropicMaterial.isotropic(e, nu, 2700.0)),))
    a, b, d = lam.abd()
    pattern = np.array([[1, nu, 0], [nu, 1, 0], [0, 0, (1 - nu) / 2]])
    np.testing.assert_allclose(a, e * t / (1 - nu**2) * pattern, rtol=1e-12, atol=1e-3)
    np.testing.assert_allclose(d, e * t**3 / (12 * (1 - nu**2)) * pattern, rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(b, 0.0, atol=1e-6)
    assert lam.is_symmetric()


def test_symmetric_cross_ply_matches_hand_computation():
    """[0/90]s with plies of thickness t: interfaces at -2t, -t, 0, t, 2t."""
    t = 0.25e-3
    lam = Laminate(tuple(Ply(t, a, CFRP) for a in (0, 90, 90, 0)))
    q11, q22, q12, q66 = q_matrix(CFRP)
    a, b, d = lam.abd()
    # outer 0 deg plies: int z^2 over |z| in [t, 2t] = 7 t^3 / 3 each; inner 90 deg plies: t^3 / 3 each
    assert d[0, 0] == pytest.approx((14 * q11 + 2 * q22) * t**3 / 3, rel=1e-12)
    assert d[1, 1] == pytest.approx((14 * q22 + 2 * q11) * t**3 / 3, rel=1e-12)
    assert d[0, 1] == pytest.approx(16 * q12 * t**3 / 3, rel=1e-12)
    assert d[2, 2] == pytest.approx(16 * q66 * t**3 / 3, rel=1e-12)
    assert a[0, 0] == pytest.approx(2 * t * (q11 + q22), rel=1e-12)
    assert abs(d[0, 2]) + abs(d[1, 2]) + abs(a[0, 2]) < 1e-9 * d[0, 0]
    np.testing.assert_allclose(b, 0.0, atol=1e-9 * a[0, 0] * lam.thickness)
    assert lam.is_symmetric()


def test_unsymmetric_two_ply_has_the_hand_computed_coupling():
    t = 0.2e-3
    lam = Laminate((Ply(t, 0, CFRP), Ply(t, 90, CFRP)))
    q11, q22, _, _ = q_matrix(CFRP)
    _, b, _ = lam.abd()
    # 0 deg ply on z in [-t, 0], 90 deg ply on [0, t]: B11 = (Q22 - Q11) t^2 / 2 = -B22
    assert b[0, 0] == pytest.approx((q22 - q11) * t**2 / 2, rel=1e-12)
    assert b[1, 1] == pytest.approx(-(q22 - q11) * t**2 / 2, rel=1e-12)
    assert not lam.is_symmetric()


def test_ply_rotation_properties():
    q = Ply(1e-3, 0.0, CFRP).transformed_stiffness()
    q90 = Ply(1e-3, 90.0, CFRP).transformed_stiffness()
    assert q90[0, 0] == pytest.approx(q[1, 1]) and q90[1, 1] == pytest.approx(q[0, 0])
    np.testing.assert_allclose(Ply(1e-3, 30.0, CFRP).transformed_stiffness(),
                               Ply(1e-3, 210.0, CFRP).transformed_stiffness(), rtol=1e-12, atol=1e-3)
    # +theta and -theta differ only in the sign of the 16 and 26 terms
    qp, qm = Ply(1e-3, 35.0, CFRP).transformed_stiffness(), Ply(1e-3, -35.0, CFRP).transformed_stiffness()
    np.testing.assert_allclose(qp * [[1, 1, -1], [1, 1, -1], [-1, -1, 1]], qm, rtol=1e-12, atol=1e-3)
    # the transverse shear stiffness rotates like a second-order tensor: its trace is invariant
    cs = Ply(1e-3, 35.0, CFRP).transformed_shear_stiffness()
    assert np.trace(cs) == pytest.approx(CFRP.g13 + CFRP.g23)


def test_abd_matches_pyfe3d_clt_for_an_unsymmetric_angle_ply():
    """pyfe3d computes A, B, D with its own lamination code: an independent implementation."""
    from postcapture.panels.fem import shell_property

    glass = OrthotropicMaterial(e1=40e9, e2=12e9, nu12=0.26, g12=4.5e9, g13=4.5e9, g23=3.5e9, rho=1900.0)
    lam = Laminate((Ply(0.2e-3, 30, CFRP), Ply(0.5e-3, -45, glass), Ply(0.3e-3, 60, CFRP),
                    Ply(0.1e-3, 0, glass)))
    a, b, d = lam.abd()
    p = shell_property(lam)
    for name, mat in (("A", a), ("B", b), ("D", d)):
        entries = {(0, 0): "11", (0, 1): "12", (0, 2): "16", (1, 1): "22", (1, 2): "26", (2, 2): "66"}
        for (i, j), ij in entries.items():
            ref = getattr(p, name + ij)
            assert mat[i, j] == pytest.approx(ref, rel=1e-10, abs=1e-10 * np.max(np.abs(mat))), name + ij
    assert lam.areal_mass == pytest.approx(p.intrho, rel=1e-12)


def test_cell_mass_goes_into_the_top_ply_density():
    lam = Laminate((Ply(1e-3, 0, CFRP), Ply(4e-3, 0, CFRP), Ply(1e-3, 0, CFRP)), cell_mass=2.0)
    top = lam.effective_plies()[-1]
    assert top.material.rho == pytest.approx(CFRP.rho + 2.0 / 1e-3)
    assert lam.plies[-1].material.rho == CFRP.rho  # the structural ply is unchanged
    m0, m1, m2 = lam.mass_moments()
    assert m0 == pytest.approx(6e-3 * CFRP.rho + 2.0) == pytest.approx(lam.areal_mass)
    # the cells sit in the top ply, centred at z = 2.5 mm: first moment 2.0 * 2.5e-3
    assert m1 == pytest.approx(2.0 * 2.5e-3, rel=1e-12)
    assert m2 > CFRP.rho * (6e-3) ** 3 / 12


def test_equivalent_beam_of_an_isotropic_strip():
    e, nu, t, b = 70e9, 0.3, 1e-3, 0.2
    lam = Laminate((Ply(t, 0, OrthotropicMaterial.isotropic(e, nu, 2700.0)),))
    beam = equivalent_beam(lam, b)
    assert beam.bending_stiffness == pytest.approx(e * b * t**3 / 12, rel=1e-12)
    assert beam.plate_bending_stiffness == pytest.approx(e * b * t**3 / (12 * (1 - nu**2)), rel=1e-12)
    assert beam.torsional_stiffness == pytest.approx(e / (2 * (1 + nu)) * b * t**3 / 3, rel=1e-12)
    assert beam.mass_per_length == pytest.approx(2700.0 * t * b)
    np.testing.assert_allclose(beam.bending_stiffness_at([0.0, 0.5]), beam.bending_stiffness)


def test_from_dict_round_trip():
    spec = {"name": "demo", "cell_mass": 1.5,
            "materials": {"cf": {"e1": 140e9, "e2": 9e9, "nu12": 0.3, "g12": 5e9, "g13": 5e9, "g23": 3e9,
                                 "rho": 1550.0}},
            "plies": [{"thickness": 1e-4, "angle_deg": 0, "material": "cf"},
                      {"thickness": 1e-4, "angle_deg": 90, "material": "cf"}]}
    lam = Laminate.from_dict(spec)
    assert lam.name == "demo" and lam.cell_mass == 1.5 and len(lam.plies) == 2
    assert lam.plies[1].angle_deg == 90.0 and lam.plies[0].material.e1 == 140e9


@pytest.mark.parametrize("thickness, match", [
    (0.0, r"ply\.thickness: expected a finite thickness > 0 m, found 0\.0"),
    (-1e-3, r"thickness.*-0\.001"),
    (math.nan, r"thickness.*nan"),
])
def test_bad_ply_thickness(thickness, match):
    with pytest.raises(PanelModelError, match=match):
        Ply(thickness, 0.0, CFRP)


def test_non_positive_definite_orthotropic_material():
    with pytest.raises(PanelModelError, match=r"nu12: expected \|nu12\| < sqrt\(e1/e2\)"):
        OrthotropicMaterial(e1=10e9, e2=100e9, nu12=0.5, g12=5e9, g13=5e9, g23=3e9, rho=1500.0)


def test_non_orthotropic_material_in_a_spec():
    spec = {"materials": {"aniso": {"e1": 140e9, "e2": 9e9, "nu12": 0.3, "g12": 5e9, "g13": 5e9, "g23": 3e9,
                                    "rho": 1550.0, "e16": 2e9}},
            "plies": [{"thickness": 1e-4, "angle_deg": 0, "material": "aniso"}]}
    with pytest.raises(PanelModelError, match=r"materials\.aniso\.e16: expected an orthotropic material"):
        Laminate.from_dict(spec)


def test_negative_moduli_are_all_reported():
    with pytest.raises(PanelModelError, match="2 problems") as info:
        OrthotropicMaterial(e1=-1.0, e2=9e9, nu12=0.3, g12=5e9, g13=0.0, g23=3e9, rho=1500.0, name="bad")
    assert [p.path for p in info.value.problems] == ["bad.e1", "bad.g13"]
    assert isinstance(info.value, ValueError)


def test_negative_density_and_cell_mass():
    with pytest.raises(PanelModelError, match=r"rho: expected >= 0"):
        OrthotropicMaterial.isotropic(70e9, 0.3, -1.0)
    with pytest.raises(PanelModelError, match=r"cell_mass: expected a finite areal mass >= 0"):
        Laminate((Ply(1e-3, 0, CFRP),), cell_mass=-0.1)


def test_empty_ply_list_and_wrong_ply_type():
    with pytest.raises(PanelModelError, match="plies: expected at least one ply"):
        Laminate(())
    with pytest.raises(PanelModelError, match=r"plies\[1\]: expected a Ply, found dict"):
        Laminate((Ply(1e-3, 0, CFRP), {"thickness": 1e-3}))


def test_from_dict_collects_every_problem():
    spec = {"materials": {"cf": {"e1": 140e9, "e2": 9e9, "nu12": 5.0, "g12": -5e9, "g13": 5e9, "g23": 3e9,
                                 "rho": 1550.0, "g16": 1e9}},
            "plies": [{"thickness": 0.0, "angle_deg": 0, "material": "cf"},
                      {"thickness": 1e-4, "angle_deg": 0, "material": "glass"}],
            "colour": "blue"}
    with pytest.raises(PanelModelError, match="invalid panel model") as info:
        Laminate.from_dict(spec, source="panel.toml")
    paths = {p.path for p in info.value.problems}
    assert paths == {"colour", "materials.cf.g16", "materials.cf.g12", "materials.cf.nu12",
                     "plies[0].thickness", "plies[1].material"}
    assert "panel.toml" in str(info.value)


def test_equivalent_beam_rejects_a_bad_width():
    with pytest.raises(PanelModelError, match="width: expected a finite width > 0 m"):
        equivalent_beam(Laminate((Ply(1e-3, 0, CFRP),)), 0.0)
