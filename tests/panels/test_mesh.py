"""Structured panel mesh: numbering, orientation, edges, mirror map and bad input."""

import numpy as np
import pytest

from postcapture.core.errors import PanelModelError
from postcapture.panels import PanelGeometry, panel_mesh


def test_mesh_layout():
    mesh = panel_mesh(PanelGeometry(14.0, 5.0), n_length=60, n_width=20)
    assert (mesh.n_nodes, mesh.n_elements) == (61 * 21, 1200)
    np.testing.assert_allclose(mesh.element_areas(), 14.0 * 5.0 / 1200)
    np.testing.assert_allclose(mesh.nodes[mesh.root_nodes, 0], 0.0)
    np.testing.assert_allclose(mesh.nodes[mesh.tip_nodes, 0], 14.0)
    np.testing.assert_allclose(mesh.nodes[mesh.root_nodes, 1], np.linspace(-2.5, 2.5, 21))
    # counter-clockwise about +z with the first edge along +x (element x-axis = panel x-axis)
    p = mesh.nodes[mesh.quads]
    first_edge = p[:, 1] - p[:, 0]
    assert np.all(first_edge[:, 0] > 0) and np.allclose(first_edge[:, 1], 0.0)
    normal_z = np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 1])[:, 2]
    assert np.all(normal_z > 0)
    mirrored = mesh.nodes[mesh.mirror]
    np.testing.assert_allclose(mirrored[:, 0], mesh.nodes[:, 0])
    np.testing.assert_allclose(mirrored[:, 1], -mesh.nodes[:, 1], atol=1e-12)
    np.testing.assert_allclose(mesh.stations, np.linspace(0.0, 14.0, 61))


@pytest.mark.parametrize("kw, match", [
    ({"n_length": 0}, r"n_length: expected an integer >= 1 \(a mesh needs at least one element\), found 0"),
    ({"n_width": -3}, r"n_width: expected an integer >= 1"),
    ({"n_width": True}, r"n_width: expected an integer >= 1"),
])
def test_mesh_without_elements(kw, match):
    with pytest.raises(PanelModelError, match=match):
        panel_mesh(PanelGeometry(1.0, 1.0), **kw)


def test_bad_geometry_reports_both_dimensions():
    with pytest.raises(PanelModelError, match="2 problems") as info:
        PanelGeometry(0.0, float("inf"), name="wing")
    assert [p.path for p in info.value.problems] == ["length", "width"]
    assert "invalid panel model 'wing'" in str(info.value)
