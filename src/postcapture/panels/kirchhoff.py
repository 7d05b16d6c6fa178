"""Independent check of the shell FEM: a Kirchhoff plate in scikit-fem.

Everything differs from `postcapture.panels.fem` except the laminate: another library (scikit-fem),
another theory (Kirchhoff-Love plate, no transverse shear, no rotary inertia, no membrane), another
element (Morley's non-conforming quadratic triangle, whose DoF are the vertex deflections and the
normal slopes at edge mid-points) and its own CLT (the bending matrix of `Laminate.abd`, reduced as
``D* = D - B A^-1 B`` for a laminate free to stretch). The clamp sets the deflection and the normal
slope to zero on the root edge. For a thin symmetric panel the two models must agree on the
out-of-plane modes to within their discretisation errors.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.sparse.linalg import eigsh

from postcapture.core.errors import MissingExtraError, PanelModelError, Problem
from postcapture.panels.laminate import Laminate
from postcapture.panels.mesh import PanelGeometry

__all__ = ["KirchhoffModes", "solve_modes_kirchhoff"]


@dataclass(frozen=True)
class KirchhoffModes:
    """Out-of-plane modes of the Kirchhoff plate.

    Attributes
    ----------
    frequencies_hz : ndarray, shape (n_modes,)
        Natural frequencies, ascending (Hz).
    kinds : tuple of str
        ``"bending"`` (deflection symmetric across ``y = 0``) or ``"torsion"`` (antisymmetric).
    vertices : ndarray, shape (n_vertices, 2)
        Vertex coordinates ``(x, y)`` in the panel frame P (m).
    deflections : ndarray, shape (n_vertices, n_modes)
        Mass-normalised deflection ``w`` at the vertices (m/sqrt(kg)).
    """

    frequencies_hz: np.ndarray
    kinds: tuple[str, ...]
    vertices: np.ndarray
    deflections: np.ndarray

    def frequency(self, kind: str, order: int = 1) -> float:
        """Return the frequency (Hz) of the ``order``-th mode (1-based) of a kind."""
        idx = np.flatnonzero(np.asarray(self.kinds) == kind)
        if not 1 <= order <= idx.size:
            raise PanelModelError([Problem(f"{kind} mode {order}", "computed (raise n_modes)",
                                           f"{idx.size} {kind} modes")])
        return float(self.frequencies_hz[idx[order - 1]])


def solve_modes_kirchhoff(geometry: PanelGeometry, laminate: Laminate, *, n_length: int = 60,
                          n_width: int = 20, n_modes: int = 6) -> KirchhoffModes:
    """Compute the cantilever plate modes with scikit-fem's Morley element.

    Parameters
    ----------
    geometry : PanelGeometry
        The panel, clamped at ``x = 0``.
    laminate : Laminate
        Its section (only ``D* = D - B A^-1 B`` and the areal mass enter).
    n_length, n_width : int, optional
        Grid cells along and across; each cell is cut into two triangles. Default 60 x 20.
    n_modes : int, optional
        Number of modes. Default 6.

    Returns
    -------
    KirchhoffModes

    Raises
    ------
    PanelModelError
        If a cell count is not an integer >= 1.
    MissingExtraError
        If scikit-fem is not installed.
    """
    try:
        from skfem import Basis, BilinearForm, ElementTriMorley, MeshTri, asm
    except ImportError as exc:  # pragma: no cover - scikit-fem is part of the panels extra
        raise MissingExtraError("scikit-fem", "panels") from exc
    problems = [Problem(k, "an integer >= 1 (a mesh needs at least one element)", repr(n))
                for k, n in (("n_length", n_length), ("n_width", n_width))
                if isinstance(n, bool) or not isinstance(n, (int, np.integer)) or n < 1]
    if problems:
        raise PanelModelError(problems, source=geometry.name or None)

    a, b, d = laminate.abd()
    d_star = d - b @ np.linalg.solve(a, b)
    rho_a = laminate.areal_mass
    mesh = MeshTri.init_tensor(np.linspace(0.0, geometry.length, n_length + 1),
                               np.linspace(-0.5 * geometry.width, 0.5 * geometry.width, n_width + 1))
    basis = Basis(mesh, ElementTriMorley())

    @BilinearForm
    def stiffness(u, v, _):
        ku = (u.hess[0, 0], u.hess[1, 1], 2.0 * u.hess[0, 1])  # curvatures, engineering twist
        kv = (v.hess[0, 0], v.hess[1, 1], 2.0 * v.hess[0, 1])
        return sum(d_star[i, j] * ku[i] * kv[j] for i in range(3) for j in range(3))

    @BilinearForm
    def mass(u, v, _):
        return rho_a * u * v

    k = asm(stiffness, basis)
    m = asm(mass, basis)
    clamped = basis.get_dofs(lambda x: np.isclose(x[0], 0.0)).all()
    free = basis.complement_dofs(clamped)
    n_free = free.size
    if not 1 <= n_modes < n_free:
        raise PanelModelError([Problem("n_modes", f"an integer in [1, {n_free - 1}]", repr(n_modes))])
    omega2, phi_f = eigsh(k[free][:, free], k=int(n_modes), M=m[free][:, free], sigma=0.0, which="LM",
                          v0=np.ones(free.size))  # a fixed start: the same modes every run
    order = np.argsort(omega2)
    omega2, phi_f = omega2[order], phi_f[:, order]
    phi = np.zeros((basis.N, phi_f.shape[1]))
    phi[free] = phi_f
    vertex_dofs = basis.nodal_dofs[0]
    w = phi[vertex_dofs]
    w /= np.sqrt(np.einsum("im,im->m", phi_f, m[free][:, free] @ phi_f))
    vertices = mesh.p.T.copy()
    # mirror of each vertex across y = 0, found on the structured grid by rounding coordinates
    key = {(round(x, 9), round(y, 9)): i for i, (x, y) in enumerate(vertices)}
    mirror = np.array([key[(round(x, 9), round(-y, 9) + 0.0)] for x, y in vertices])
    sym = np.sum((w + w[mirror]) ** 2, axis=0)
    anti = np.sum((w - w[mirror]) ** 2, axis=0)
    kinds = tuple("bending" if s >= t else "torsion" for s, t in zip(sym, anti))
    return KirchhoffModes(np.sqrt(np.abs(omega2)) / (2.0 * np.pi), kinds, vertices, w)
