"""Modal results of the cantilevered panel: classification, effective masses, centreline sampling.

`PanelModes` is what `postcapture.panels.fem.solve_modes` returns and what the lumped-chain
identification consumes: frequencies, mass-normalised shapes at the nodes, the kind of each mode
(``"bending"``, ``"torsion"``, ``"in-plane"``), effective masses, and the out-of-plane displacement and
slope along the panel centreline at any stations.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from postcapture.core.errors import PanelModelError, Problem
from postcapture.panels.mesh import PanelMesh

__all__ = ["KINDS", "DIRECTIONS", "PanelModes", "classify_modes", "rigid_body_vectors", "nodal_areas"]

KINDS = ("bending", "torsion", "in-plane")
DIRECTIONS = ("x", "y", "z", "rx", "ry", "rz")


def nodal_areas(mesh: PanelMesh) -> np.ndarray:
    """Return the tributary area of each node (a quarter of each adjacent element), shape (n_nodes,) (m^2)."""
    a = np.zeros(mesh.n_nodes)
    np.add.at(a, mesh.quads.ravel(), np.repeat(mesh.element_areas() / 4.0, 4))
    return a


def rigid_body_vectors(mesh: PanelMesh) -> np.ndarray:
    """Return the rigid-body motions about the root centre (the origin of P), shape (6 n_nodes, 6).

    Columns: unit translations along x, y, z (m) and unit rotations about x, y, z (rad), node-major DoF
    ``(u, v, w, r_x, r_y, r_z)``.
    """
    x, y, z = mesh.nodes.T
    r = np.zeros((mesh.n_nodes, 6, 6))
    for d in range(3):
        r[:, d, d] = 1.0
        r[:, 3 + d, 3 + d] = 1.0
    # displacement = omega x r for a unit rotation omega about each axis
    r[:, 1, 3], r[:, 2, 3] = -z, y
    r[:, 0, 4], r[:, 2, 4] = z, -x
    r[:, 0, 5], r[:, 1, 5] = -y, x
    return r.reshape(6 * mesh.n_nodes, 6)


def classify_modes(mesh: PanelMesh, shapes: np.ndarray) -> tuple[str, ...]:
    """Classify each mode from its nodal shape.

    Parameters
    ----------
    mesh : PanelMesh
        The mesh the shapes live on.
    shapes : ndarray, shape (n_nodes, 6, n_modes)
        Mode shapes.

    Returns
    -------
    tuple of str
        ``"in-plane"`` when the in-plane translations carry more (area-weighted) energy than the
        out-of-plane one; otherwise ``"bending"`` when the out-of-plane displacement is mostly symmetric
        across the centreline ``y = 0`` and ``"torsion"`` when it is mostly antisymmetric. Symmetric
        chordwise plate modes (nodal lines along x, far above the first few beam-like modes of a
        slender panel) also count as ``"bending"``.
    """
    area = nodal_areas(mesh)[:, None]
    u, v, w = shapes[:, 0, :], shapes[:, 1, :], shapes[:, 2, :]
    out_of_plane = np.sum(area * w**2, axis=0)
    in_plane = np.sum(area * (u**2 + v**2), axis=0)
    w_mirror = w[mesh.mirror]
    symmetric = np.sum(area * (w + w_mirror) ** 2, axis=0)
    antisymmetric = np.sum(area * (w - w_mirror) ** 2, axis=0)
    kinds = np.where(in_plane > out_of_plane, "in-plane",
                     np.where(symmetric >= antisymmetric, "bending", "torsion"))
    return tuple(str(k) for k in kinds)


@dataclass(frozen=True)
class PanelModes:
    """Normal modes of the cantilevered panel.

    Attributes
    ----------
    mesh : PanelMesh
        The mesh (node coordinates ``mesh.nodes`` in the panel frame P, m).
    frequencies_hz : ndarray, shape (n_modes,)
        Natural frequencies, ascending (Hz).
    shapes : ndarray, shape (n_nodes, 6, n_modes)
        Mass-normalised shapes (``phi^T M phi = 1``): DoF ``(u, v, w, r_x, r_y, r_z)`` per node in P
        (m/sqrt(kg) and rad/sqrt(kg)); the root nodes are zero. `solve_modes` makes the largest nodal
        translation of each mode positive.
    participation : ndarray, shape (6, n_modes), or None
        Modal participation factors ``phi^T M R`` for the rigid-body motions ``R`` of the base
        (`rigid_body_vectors`, directions `DIRECTIONS`) (sqrt(kg) and sqrt(kg) m); None for modes read
        from a file without the mass matrix.
    rigid_mass : ndarray, shape (6,), or None
        ``R^T M R`` over the free DoF: the mass (kg) moved by a base translation and the moments of
        inertia (kg m^2) about the root-centre axes; the effective masses of all modes sum to it.
    total_mass : float
        Mass of the whole panel, laminate areal mass times planform area (kg); NaN when unknown.
    kinds : tuple of str
        Kind of each mode (`KINDS`), from `classify_modes`.
    """

    mesh: PanelMesh
    frequencies_hz: np.ndarray
    shapes: np.ndarray
    participation: np.ndarray | None = None
    rigid_mass: np.ndarray | None = None
    total_mass: float = float("nan")
    kinds: tuple[str, ...] = field(default=())

    def __post_init__(self):
        if not self.kinds:
            object.__setattr__(self, "kinds", classify_modes(self.mesh, self.shapes))

    @property
    def n_modes(self) -> int:
        """Number of modes."""
        return self.frequencies_hz.size

    @property
    def node_coordinates(self) -> np.ndarray:
        """Node coordinates in P, shape (n_nodes, 3) (m)."""
        return self.mesh.nodes

    @property
    def effective_mass(self) -> np.ndarray:
        """Effective modal masses, shape (6, n_modes): kg for x, y, z and kg m^2 for rx, ry, rz.

        Raises
        ------
        PanelModelError
            If the modes carry no participation factors (read from a file).
        """
        if self.participation is None:
            raise PanelModelError([Problem("effective_mass", "modes from solve_modes (with the mass matrix)",
                                           "modes without participation factors")])
        return self.participation**2

    @property
    def effective_mass_fraction(self) -> np.ndarray:
        """Effective masses over `rigid_mass`, shape (6, n_modes) (-); each row sums to 1 over all modes."""
        eff = self.effective_mass
        return eff / self.rigid_mass[:, None]

    def indices(self, kind: str) -> np.ndarray:
        """Return the indices of the modes of one kind, ascending frequency."""
        if kind not in KINDS:
            raise PanelModelError([Problem("kind", f"one of {', '.join(KINDS)}", repr(kind))])
        return np.flatnonzero(np.asarray(self.kinds) == kind)

    def frequency(self, kind: str, order: int = 1) -> float:
        """Return the frequency (Hz) of the ``order``-th (1-based) mode of a kind, e.g. ``"torsion"``.

        Raises
        ------
        PanelModelError
            If fewer than ``order`` modes of that kind were computed.
        """
        idx = self.indices(kind)
        if not 1 <= order <= idx.size:
            raise PanelModelError([Problem(f"{kind} mode {order}", "computed (raise n_modes)",
                                           f"{idx.size} {kind} modes")])
        return float(self.frequencies_hz[idx[order - 1]])

    def centreline(self, stations, modes=None) -> tuple[np.ndarray, np.ndarray]:
        """Sample the out-of-plane displacement and slope along the centreline ``y = 0``.

        Parameters
        ----------
        stations : array_like, shape (n_stations,)
            Distances from the root, in ``[0, length]`` (m).
        modes : array_like of int, optional
            Mode indices; default all.

        Returns
        -------
        w : ndarray, shape (n_stations, n_selected)
            Displacement along z (m/sqrt(kg) for mass-normalised shapes).
        slope : ndarray, shape (n_stations, n_selected)
            ``dw/dx`` (rad/sqrt(kg)).

        Raises
        ------
        PanelModelError
            If a station lies outside the panel.

        Notes
        -----
        Between node stations the centreline is a cubic Hermite curve through the nodal ``w`` and
        slopes ``dw/dx = -r_y`` (the shell's section rotation, positive about +y). With an odd number
        of elements across the width the centreline is the mean of the two middle node rows.
        """
        s = np.atleast_1d(np.asarray(stations, dtype=float))
        length = self.mesh.geometry.length
        bad = (s < -1e-12 * length) | (s > length * (1 + 1e-12)) | ~np.isfinite(s)
        if np.any(bad):
            raise PanelModelError([Problem("stations", f"values in [0, {length:g}] m",
                                           repr(s[bad][:3].tolist()))])
        sel = np.arange(self.n_modes) if modes is None else np.atleast_1d(np.asarray(modes, dtype=int))
        nw = self.mesh.n_width
        rows = [nw // 2] if nw % 2 == 0 else [nw // 2, nw // 2 + 1]
        i = np.arange(self.mesh.n_length + 1)
        w_nodes = np.mean([self.shapes[self.mesh.node_index(i, j), 2][:, sel] for j in rows], axis=0)
        d_nodes = -np.mean([self.shapes[self.mesh.node_index(i, j), 4][:, sel] for j in rows], axis=0)
        h = length / self.mesh.n_length
        k = np.clip(np.floor(s / h).astype(int), 0, self.mesh.n_length - 1)
        xi = np.clip(s / h - k, 0.0, 1.0)[:, None]
        h1, h2 = 1 - 3 * xi**2 + 2 * xi**3, h * (xi - 2 * xi**2 + xi**3)
        h3, h4 = 3 * xi**2 - 2 * xi**3, h * (xi**3 - xi**2)
        w = h1 * w_nodes[k] + h2 * d_nodes[k] + h3 * w_nodes[k + 1] + h4 * d_nodes[k + 1]
        g1, g2 = (6 * xi**2 - 6 * xi) / h, 1 - 4 * xi + 3 * xi**2
        g3, g4 = (6 * xi - 6 * xi**2) / h, 3 * xi**2 - 2 * xi
        slope = g1 * w_nodes[k] + g2 * d_nodes[k] + g3 * w_nodes[k + 1] + g4 * d_nodes[k + 1]
        return w, slope
