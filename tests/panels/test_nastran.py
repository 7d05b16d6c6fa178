"""Nastran interchange: the BDF re-read by pyNastran, and an OP2 written by pyNastran read back."""

import sys

import numpy as np
import pytest
from panel_cases import write_modes_op2

from postcapture.core.errors import MissingExtraError, NastranError, PanelModelError
from postcapture.panels import builtin_panel, read_op2_modes, solve_modes, write_bdf
from postcapture.panels.nastran import _in1d

import pyNastran  # noqa: F401 - the panels extra is part of the test install


@pytest.fixture(scope="module")
def envisat_panel():
    return builtin_panel("envisat")


@pytest.mark.parametrize("cell_mass_as, n_mat8", [("ply_density", 3), ("nsm", 2)])
def test_bdf_cards_and_mass(tmp_path, envisat_panel, cell_mass_as, n_mat8):
    from pyNastran.bdf.bdf import BDF
    from pyNastran.bdf.mesh_utils.mass_properties import mass_properties

    geometry, laminate = envisat_panel
    path = tmp_path / "envisat.bdf"
    mesh = write_bdf(path, geometry, laminate, n_modes=12, cell_mass_as=cell_mass_as)
    model = BDF(debug=None)
    model.read_bdf(str(path))
    assert model.sol == 103
    counts = model.card_count
    assert (counts["GRID"], counts["CQUAD4"], counts["PCOMP"], counts["MAT8"]) == (61 * 21, 1200, 1, n_mat8)
    assert counts["SPC1"] == 1 and counts["EIGRL"] == 1
    spc = model.spcs[1][0]
    assert spc.components == "123456" and sorted(spc.node_ids) == list(mesh.root_nodes + 1)
    eigrl = model.methods[1]
    assert eigrl.nd == 12 and eigrl.norm == "MASS"
    pcomp = model.properties[1]
    assert pcomp.nplies == len(laminate.plies)
    assert pcomp.Thickness() == pytest.approx(laminate.thickness, rel=1e-12)
    assert pcomp.nsm == pytest.approx(laminate.cell_mass if cell_mass_as == "nsm" else 0.0)
    # areas and masses from pyNastran's own element and PCOMP formulas, against L W and areal mass x L W
    assert sum(e.Area() for e in model.elements.values()) == pytest.approx(geometry.area, rel=1e-12)
    mass, cg, _ = mass_properties(model)
    assert mass == pytest.approx(laminate.areal_mass * geometry.area, rel=1e-12)
    np.testing.assert_allclose(cg[:2], [geometry.length / 2, 0.0], atol=1e-9)
    np.testing.assert_allclose(model.nodes[mesh.n_nodes].xyz, mesh.nodes[-1])
    assert "DISPLACEMENT(PLOT) = ALL" in str(model.case_control_deck)


def test_op2_round_trip(tmp_path, strip):
    modes = solve_modes(strip.geometry, strip.laminate, n_length=12, n_width=2, n_modes=5)
    path = tmp_path / "strip.op2"
    node_ids = np.arange(1, modes.mesh.n_nodes + 1)
    write_modes_op2(path, node_ids, modes.shapes, modes.frequencies_hz)
    back = read_op2_modes(path)
    np.testing.assert_allclose(back.frequencies_hz, modes.frequencies_hz, rtol=1e-6)  # float32 in the file
    np.testing.assert_array_equal(back.node_ids, node_ids)
    np.testing.assert_allclose(back.shapes, modes.shapes, atol=1e-6 * np.abs(modes.shapes).max())
    on_mesh = back.to_panel_modes(modes.mesh)
    assert on_mesh.kinds == modes.kinds
    s = np.linspace(0.0, strip.length, 6)
    np.testing.assert_allclose(on_mesh.centreline(s)[0], modes.centreline(s)[0],
                               atol=1e-6 * np.abs(modes.shapes).max())


def test_op2_nodes_must_match_the_mesh(tmp_path, strip):
    modes = solve_modes(strip.geometry, strip.laminate, n_length=4, n_width=1, n_modes=2)
    path = tmp_path / "shifted.op2"
    write_modes_op2(path, np.arange(101, 101 + modes.mesh.n_nodes), modes.shapes, modes.frequencies_hz)
    with pytest.raises(NastranError, match=r"shifted\.op2: its 10 GRIDs are not the 10 nodes 1\.\.10"):
        read_op2_modes(path).to_panel_modes(modes.mesh)


def test_op2_without_eigenvectors(tmp_path, strip):
    modes = solve_modes(strip.geometry, strip.laminate, n_length=4, n_width=1, n_modes=2)
    path = tmp_path / "static.op2"
    ids = np.arange(1, modes.mesh.n_nodes + 1)
    write_modes_op2(path, ids, modes.shapes, modes.frequencies_hz, eigenvectors=False)
    with pytest.raises(NastranError, match=r"static\.op2: no real eigenvectors in it .*displacements"):
        read_op2_modes(path)


def test_missing_or_unreadable_op2(tmp_path):
    with pytest.raises(NastranError, match="no such file"):
        read_op2_modes(tmp_path / "absent.op2")
    junk = tmp_path / "junk.op2"
    junk.write_bytes(b"this is not a fortran binary file" * 10)
    with pytest.raises(NastranError, match=r"junk\.op2: pyNastran cannot read it as an OP2"):
        read_op2_modes(junk)


def test_bad_bdf_options(tmp_path, envisat_panel):
    with pytest.raises(PanelModelError, match=r"2 problems(.|\n)*cell_mass_as: expected one of ply_density"):
        write_bdf(tmp_path / "x.bdf", *envisat_panel, cell_mass_as="glue", n_modes=0)
    with pytest.raises(PanelModelError, match="n_length: expected an integer >= 1"):
        write_bdf(tmp_path / "x.bdf", *envisat_panel, n_length=0)


def test_missing_pynastran_names_the_extra(tmp_path, envisat_panel, monkeypatch):
    monkeypatch.setitem(sys.modules, "pyNastran.bdf.bdf", None)
    with pytest.raises(MissingExtraError, match=r"pyNastran is not installed.*postcapture\[panels\]"):
        write_bdf(tmp_path / "x.bdf", *envisat_panel)


def test_in1d_shim_has_numpy_semantics():
    a = np.array([[1, 5], [3, 7]])
    np.testing.assert_array_equal(_in1d(a, [3, 5]), [False, True, True, False])
    np.testing.assert_array_equal(_in1d(a, [3, 5], invert=True), [True, False, False, True])
