"""Modal analysis of the cantilevered composite panel with pyfe3d's composite Quad4 shell.

The panel is meshed with `panel_mesh`, each quadrilateral is a pyfe3d ``Quad4`` (first-order shear
deformation shell, the closest open analogue of a Nastran CQUAD4 with a PCOMP section: bilinear
displacements and rotations, 2 x 2 bending quadrature, one-point transverse shear, drilling
rotation with stiffness), the section is built by pyfe3d from the same plies as the `Laminate`
(with the cell mass in the top ply's density), the root edge is clamped in all six DoF, and the
generalised eigenproblem ``K phi = omega^2 M phi`` is solved by scipy's ARPACK in shift-invert mode.

DoF order: node-major, ``(u, v, w, r_x, r_y, r_z)`` per node in the panel frame P (m, rad).
"""

from __future__ import annotations

import logging
import time

import numpy as np
import scipy.sparse as sp
from scipy.sparse.linalg import eigsh

from postcapture.core.errors import PanelModelError, Problem
from postcapture.panels.laminate import Laminate
from postcapture.panels.mesh import PanelGeometry, PanelMesh, panel_mesh
from postcapture.panels.modes import PanelModes, rigid_body_vectors

__all__ = ["DOF_PER_NODE", "shell_property", "assemble", "clamped_dofs", "solve_modes"]

logger = logging.getLogger(__name__)

DOF_PER_NODE = 6


def _pyfe3d():
    try:
        import pyfe3d
        from pyfe3d.shellprop_utils import laminated_plate
    except ImportError as exc:  # pragma: no cover - pyfe3d is part of the panels extra
        from postcapture.core.errors import MissingExtraError

        raise MissingExtraError("pyfe3d", "panels") from exc
    return pyfe3d, laminated_plate


def shell_property(laminate: Laminate):
    """Build the pyfe3d ``ShellProp`` of a laminate, with the cell mass in the top ply's density.

    Parameters
    ----------
    laminate : Laminate
        The section; plies bottom to top, reference surface at mid-thickness.

    Returns
    -------
    pyfe3d.shellprop.ShellProp
        With ``A11 ... D66`` computed by pyfe3d itself (an independent CLT implementation) and the
        transverse shear stiffness corrected by Rohwer's equilibrium approach.
    """
    _, laminated_plate = _pyfe3d()
    plies = laminate.effective_plies()
    return laminated_plate(
        stack=[p.angle_deg for p in plies],
        plyts=[p.thickness for p in plies],
        laminaprops=[(p.material.e1, p.material.e2, p.material.nu12, p.material.g12, p.material.g13,
                      p.material.g23) for p in plies],
        rhos=[p.material.rho for p in plies],
        offset=0.0,
    )


def assemble(mesh: PanelMesh, laminate: Laminate, *, lumped_mass: bool = False
             ) -> tuple[sp.csc_matrix, sp.csc_matrix]:
    """Assemble the global stiffness and mass matrices of the unconstrained panel.

    Parameters
    ----------
    mesh : PanelMesh
        The panel mesh.
    laminate : Laminate
        The section of every element.
    lumped_mass : bool, optional
        Use pyfe3d's lumped (nodal) mass instead of the consistent mass. Default False.

    Returns
    -------
    K : scipy.sparse.csc_matrix, shape (6 n_nodes, 6 n_nodes)
        Stiffness (N/m, N, N m blocks).
    M : scipy.sparse.csc_matrix, shape (6 n_nodes, 6 n_nodes)
        Mass (kg, kg m, kg m^2 blocks); the drilling rotation carries no inertia.

    Raises
    ------
    PanelModelError
        If the mesh has no element.
    """
    if mesh.n_elements == 0:
        raise PanelModelError([Problem("mesh", "at least one element", "0 elements")])
    pyfe3d = _pyfe3d()[0]
    prop = shell_property(laminate)
    data = pyfe3d.Quad4Data()
    probe = pyfe3d.Quad4Probe()
    n_el = mesh.n_elements
    n_dof = DOF_PER_NODE * mesh.n_nodes
    kr = np.zeros(data.KC0_SPARSE_SIZE * n_el, dtype=pyfe3d.INT)
    kc = np.zeros_like(kr)
    kv = np.zeros(data.KC0_SPARSE_SIZE * n_el, dtype=pyfe3d.DOUBLE)
    mr = np.zeros(data.M_SPARSE_SIZE * n_el, dtype=pyfe3d.INT)
    mc = np.zeros_like(mr)
    mv = np.zeros(data.M_SPARSE_SIZE * n_el, dtype=pyfe3d.DOUBLE)
    coords = np.ascontiguousarray(mesh.nodes.ravel(), dtype=np.float64)
    mtype = 1 if lumped_mass else 0
    for e, (n1, n2, n3, n4) in enumerate(mesh.quads):
        quad = pyfe3d.Quad4(probe)
        quad.n1, quad.n2, quad.n3, quad.n4 = int(n1), int(n2), int(n3), int(n4)
        quad.c1, quad.c2 = DOF_PER_NODE * int(n1), DOF_PER_NODE * int(n2)
        quad.c3, quad.c4 = DOF_PER_NODE * int(n3), DOF_PER_NODE * int(n4)
        quad.init_k_KC0 = e * data.KC0_SPARSE_SIZE
        quad.init_k_M = e * data.M_SPARSE_SIZE
        quad.update_rotation_matrix(coords)
        quad.update_probe_xe(coords)
        quad.update_KC0(kr, kc, kv, prop)
        quad.update_M(mr, mc, mv, prop, mtype=mtype)
    used = slice(0, None) if mtype == 0 else _lumped_entries(data, n_el)
    k = sp.coo_matrix((kv, (kr, kc)), shape=(n_dof, n_dof)).tocsc()
    m = sp.coo_matrix((mv[used], (mr[used], mc[used])), shape=(n_dof, n_dof)).tocsc()
    return k, m


def _lumped_entries(data, n_el: int) -> np.ndarray:
    """Return the positions written by pyfe3d's lumped mass (the first 120 of each element's block)."""
    base = np.arange(n_el)[:, None] * data.M_SPARSE_SIZE
    return (base + np.arange(120)[None, :]).ravel()


def clamped_dofs(mesh: PanelMesh) -> np.ndarray:
    """Return the mask of the DoF fixed by the root clamp (six DoF per root node), shape (6 n_nodes,)."""
    fixed = np.zeros(DOF_PER_NODE * mesh.n_nodes, dtype=bool)
    for d in range(DOF_PER_NODE):
        fixed[DOF_PER_NODE * mesh.root_nodes + d] = True
    return fixed


def solve_modes(geometry: PanelGeometry, laminate: Laminate, *, n_length: int = 60, n_width: int = 20,
                n_modes: int = 10, lumped_mass: bool = False) -> PanelModes:
    """Compute natural frequencies and mode shapes of the cantilevered panel.

    Parameters
    ----------
    geometry : PanelGeometry
        The panel (clamped on the short edge at ``x = 0``).
    laminate : Laminate
        Its section.
    n_length, n_width : int, optional
        Elements along the length and across the width. Default 60 x 20, the reference's mesh.
    n_modes : int, optional
        Number of modes, lowest first. Default 10.
    lumped_mass : bool, optional
        Lumped instead of consistent mass matrix. Default False.

    Returns
    -------
    PanelModes
        Frequencies, mass-normalised shapes, classification and effective masses.

    Raises
    ------
    PanelModelError
        If the mesh would have no element, or ``n_modes`` is not between 1 and the number of free DoF - 1.
    """
    mesh = panel_mesh(geometry, n_length=n_length, n_width=n_width)
    free = ~clamped_dofs(mesh)
    n_free = int(free.sum())
    if isinstance(n_modes, bool) or not isinstance(n_modes, (int, np.integer)) or not 1 <= n_modes < n_free:
        raise PanelModelError([Problem("n_modes", f"an integer in [1, {n_free - 1}]", repr(n_modes))])
    t0 = time.perf_counter()
    k, m = assemble(mesh, laminate, lumped_mass=lumped_mass)
    kff = k[free][:, free]
    mff = m[free][:, free]
    t1 = time.perf_counter()
    # Shift-invert about zero: the clamp removes the rigid-body modes, so K_ff is positive definite and
    # the lowest eigenvalues are the ones nearest the shift; the massless drilling DoF only produce
    # eigenvalues at infinity, which shift-invert never reaches.
    omega2, phi_f = eigsh(kff, k=int(n_modes), M=mff, sigma=0.0, which="LM",
                          v0=np.ones(kff.shape[0]))  # a fixed start: the same modes, bit for bit, every run
    order = np.argsort(omega2)
    omega2, phi_f = omega2[order], phi_f[:, order]
    phi_f /= np.sqrt(np.einsum("im,im->m", phi_f, mff @ phi_f))  # phi^T M phi = 1
    t2 = time.perf_counter()
    logger.debug("panel %s: %d x %d mesh, %d free DoF, assembly %.3f s, eigensolve %.3f s",
                 geometry.name, n_length, n_width, n_free, t1 - t0, t2 - t1)
    if np.any(omega2 <= 0.0):
        logger.warning("non-positive eigenvalue in the clamped panel: %s", omega2[omega2 <= 0.0])
    phi = np.zeros((DOF_PER_NODE * mesh.n_nodes, phi_f.shape[1]))
    phi[free] = phi_f
    # sign convention: the largest nodal translation of each mode is positive
    translations = phi.reshape(mesh.n_nodes, DOF_PER_NODE, -1)[:, :3, :].reshape(-1, phi.shape[1])
    sign = np.sign(translations[np.argmax(np.abs(translations), axis=0), np.arange(phi.shape[1])])
    phi *= sign
    phi_f *= sign
    rigid_f = rigid_body_vectors(mesh)[free]
    gamma = phi_f.T @ (mff @ rigid_f)  # (n_modes, 6) participation factors
    rigid_mass = np.einsum("id,id->d", rigid_f, mff @ rigid_f)
    return PanelModes(
        mesh=mesh,
        frequencies_hz=np.sqrt(np.abs(omega2)) / (2.0 * np.pi),
        shapes=phi.reshape(mesh.n_nodes, DOF_PER_NODE, -1),
        participation=gamma.T.copy(),
        rigid_mass=rigid_mass,
        total_mass=laminate.areal_mass * geometry.area,
    )

