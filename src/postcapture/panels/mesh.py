"""Geometry and structured quadrilateral mesh of a rectangular panel cantilevered on a short edge.

Panel frame P: origin at the middle of the clamped root edge, x along the panel length (root at
``x = 0``, tip at ``x = length``), y across the width (centreline ``y = 0``, edges at ``+-width/2``),
z along the panel normal (the cell side is ``+z``).

Nodes are numbered ``i * (n_width + 1) + j`` with ``i = 0..n_length`` along x and ``j = 0..n_width``
along y; quadrilaterals are counter-clockwise about +z, their first edge along +x (so that a PCOMP /
pyfe3d element x-axis, and with it the 0 deg ply direction, is the panel's x-axis).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from postcapture.core.errors import PanelModelError, Problem

__all__ = ["PanelGeometry", "PanelMesh", "panel_mesh"]


@dataclass(frozen=True, slots=True)
class PanelGeometry:
    """A flat rectangular panel clamped on its root short edge.

    Parameters
    ----------
    length : float
        Length from the clamped root to the free tip, along x (m).
    width : float
        Width across the panel, along y (m).
    name : str, optional
        Label used in files and messages.

    Raises
    ------
    PanelModelError
        If a dimension is not positive and finite.
    """

    length: float
    width: float
    name: str = ""

    def __post_init__(self):
        problems = []
        for key in ("length", "width"):
            v = getattr(self, key)
            if not isinstance(v, (int, float, np.floating, np.integer)) or not math.isfinite(v) or v <= 0:
                problems.append(Problem(key, "a finite length > 0 m", repr(v)))
        if problems:
            raise PanelModelError(problems, source=self.name or None)
        object.__setattr__(self, "length", float(self.length))
        object.__setattr__(self, "width", float(self.width))

    @property
    def area(self) -> float:
        """Planform area (m^2)."""
        return self.length * self.width


@dataclass(frozen=True, slots=True)
class PanelMesh:
    """Structured mesh of a `PanelGeometry`.

    Attributes
    ----------
    geometry : PanelGeometry
        The panel.
    n_length, n_width : int
        Number of elements along the length and across the width.
    nodes : ndarray, shape (n_nodes, 3)
        Node coordinates ``r_P`` in the panel frame (m).
    quads : ndarray, shape (n_elements, 4)
        Node indices of each quadrilateral, counter-clockwise about +z.
    """

    geometry: PanelGeometry
    n_length: int
    n_width: int
    nodes: np.ndarray
    quads: np.ndarray

    @property
    def n_nodes(self) -> int:
        """Number of nodes."""
        return self.nodes.shape[0]

    @property
    def n_elements(self) -> int:
        """Number of quadrilaterals."""
        return self.quads.shape[0]

    def node_index(self, i, j) -> np.ndarray:
        """Return the index of the node at station ``i`` along x and row ``j`` along y (arrays broadcast)."""
        return np.asarray(i) * (self.n_width + 1) + np.asarray(j)

    @property
    def stations(self) -> np.ndarray:
        """Coordinates x of the node stations, shape (n_length + 1,) (m)."""
        return np.linspace(0.0, self.geometry.length, self.n_length + 1)

    @property
    def root_nodes(self) -> np.ndarray:
        """Indices of the clamped nodes (``x = 0``), shape (n_width + 1,)."""
        return self.node_index(0, np.arange(self.n_width + 1))

    @property
    def tip_nodes(self) -> np.ndarray:
        """Indices of the nodes on the free tip edge (``x = length``), shape (n_width + 1,)."""
        return self.node_index(self.n_length, np.arange(self.n_width + 1))

    @property
    def mirror(self) -> np.ndarray:
        """For each node, the index of its mirror image across the centreline ``y = 0``, shape (n_nodes,)."""
        i, j = np.divmod(np.arange(self.n_nodes), self.n_width + 1)
        return self.node_index(i, self.n_width - j)

    def element_areas(self) -> np.ndarray:
        """Area of each element, shape (n_elements,) (m^2)."""
        p = self.nodes[self.quads]
        d1 = p[:, 2, :2] - p[:, 0, :2]
        d2 = p[:, 3, :2] - p[:, 1, :2]
        return 0.5 * np.abs(d1[:, 0] * d2[:, 1] - d1[:, 1] * d2[:, 0])


def panel_mesh(geometry: PanelGeometry, *, n_length: int = 60, n_width: int = 20) -> PanelMesh:
    """Mesh the panel with ``n_length`` x ``n_width`` quadrilaterals.

    Parameters
    ----------
    geometry : PanelGeometry
        The panel.
    n_length : int, optional
        Elements along the length (x). Default 60, as the reference's 20 x 60 mesh.
    n_width : int, optional
        Elements across the width (y). Default 20.

    Returns
    -------
    PanelMesh

    Raises
    ------
    PanelModelError
        If a count is not an integer >= 1 (a mesh without elements).
    """
    problems = []
    for key, n in (("n_length", n_length), ("n_width", n_width)):
        if isinstance(n, bool) or not isinstance(n, (int, np.integer)) or n < 1:
            problems.append(Problem(key, "an integer >= 1 (a mesh needs at least one element)", repr(n)))
    if problems:
        raise PanelModelError(problems, source=geometry.name or None)
    x = np.linspace(0.0, geometry.length, n_length + 1)
    y = np.linspace(-0.5 * geometry.width, 0.5 * geometry.width, n_width + 1)
    xx, yy = np.meshgrid(x, y, indexing="ij")
    nodes = np.column_stack([xx.ravel(), yy.ravel(), np.zeros(xx.size)])
    ii, jj = np.meshgrid(np.arange(n_length), np.arange(n_width), indexing="ij")
    ii, jj = ii.ravel(), jj.ravel()
    row = n_width + 1
    n1 = ii * row + jj
    quads = np.column_stack([n1, n1 + row, n1 + row + 1, n1 + 1])
    return PanelMesh(geometry, int(n_length), int(n_width), nodes, quads)
