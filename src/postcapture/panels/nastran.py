"""Nastran interchange with pyNastran: the panel as SOL 103 bulk data out, modal results from an OP2 in.

`write_bdf` writes the same model that `postcapture.panels.fem.solve_modes` solves (GRID per node,
CQUAD4 per element, one PCOMP of MAT8 plies, SPC1 on the root, EIGRL with mass normalisation, SOL 103
with the eigenvectors requested in the OP2, ``ENDDATA`` last), so users can run it in their Nastran. The solar-cell mass
goes either into the density of the top ply, as the reference did, or onto the PCOMP as non-structural
mass (NSM), because some open solvers mishandle per-ply densities in the PCOMP mass.

`read_op2_modes` reads the eigenvectors (and their eigenvalues) back as the identification's reference.

Units: SI throughout (m, kg, s, N, Pa), so ``PARAM,WTMASS`` is 1.

pyNastran and numpy 2
---------------------
The ``panels`` extra pins ``pyNastran>=1.3.4,<1.4``: pyNastran 1.4.x declares ``numpy<2``, which cannot
resolve together with Pinocchio 4 (its ``cmeel-boost`` needs ``numpy>=2``), while 1.3.4 declares no upper
bound. pyNastran 1.3.4 uses one numpy name that numpy 2.4 removed, ``numpy.in1d`` (imported when
``pyNastran.op2`` is loaded, called by the BDF and OP2 code); before the first pyNastran import,
`_numpy_compat` puts it back on the numpy module (process-wide, only when it is missing) with numpy's own
deprecated definition (``isin`` of the flattened input). Nothing else is patched. Its OP2 reader also
calls ``np.chararray``, deprecated in numpy 2 but still present in 2.4: that DeprecationWarning is
silenced while reading, and a future numpy that drops the name will need one more alias here.
pyNastran is imported lazily, inside the functions that need it.
"""

from __future__ import annotations

import logging
import os
import warnings
from dataclasses import dataclass

import numpy as np

from postcapture.core.errors import MissingExtraError, NastranError, PanelModelError, Problem
from postcapture.io import write_atomic
from postcapture.panels.laminate import Laminate
from postcapture.panels.mesh import PanelGeometry, PanelMesh, panel_mesh
from postcapture.panels.modes import PanelModes

__all__ = ["CELL_MASS_OPTIONS", "write_bdf", "Op2Modes", "read_op2_modes"]

logger = logging.getLogger(__name__)
_PYNASTRAN_LOG = logging.getLogger(__name__ + ".pynastran")

CELL_MASS_OPTIONS = ("ply_density", "nsm")


def _in1d(ar1, ar2, assume_unique=False, invert=False):
    """Test membership of the flattened ``ar1`` in ``ar2``: numpy's ``in1d``, removed in numpy 2.4."""
    return np.isin(np.asarray(ar1).ravel(), ar2, assume_unique=assume_unique, invert=invert)


def _numpy_compat() -> None:
    """Restore the numpy names pyNastran 1.3.x needs and numpy 2.x removed (only if missing)."""
    if not hasattr(np, "in1d"):
        np.in1d = _in1d
        logger.debug("numpy %s has no in1d: restored it for pyNastran", np.__version__)


def _pynastran():
    """Import pyNastran lazily, with the numpy shim; `MissingExtraError` if it is not installed."""
    _numpy_compat()
    try:
        from pyNastran.bdf.bdf import BDF
        from pyNastran.bdf.case_control_deck import CaseControlDeck
        from pyNastran.op2.op2 import OP2
    except ImportError as exc:
        raise MissingExtraError("pyNastran", "panels") from exc
    return BDF, CaseControlDeck, OP2


def write_bdf(path, geometry: PanelGeometry, laminate: Laminate, *, n_length: int = 60, n_width: int = 20,
              n_modes: int = 10, cell_mass_as: str = "ply_density", title: str = "") -> PanelMesh:
    """Write the cantilevered panel as a Nastran SOL 103 input file.

    Parameters
    ----------
    path : str or os.PathLike
        Output file (``.bdf``/``.dat``), written in large-field format, atomically (a regular file or
        nothing there yet).
    geometry : PanelGeometry
        The panel, clamped on the edge ``x = 0``.
    laminate : Laminate
        The section (plies bottom to top, cell mass on the top face).
    n_length, n_width : int, optional
        Elements along the length and across the width. Default 60 x 20.
    n_modes : int, optional
        Number of modes requested on the EIGRL card. Default 10.
    cell_mass_as : {"ply_density", "nsm"}, optional
        ``"ply_density"`` raises the density of the top ply (its own MAT8), as the reference;
        ``"nsm"`` keeps the structural densities and puts the cell mass on the PCOMP as NSM (kg/m^2).
    title : str, optional
        TITLE of the case control; default the panel's name.

    Returns
    -------
    PanelMesh
        The mesh written: GRID ``i + 1`` is ``mesh.nodes[i]``, CQUAD4 ``e + 1`` is ``mesh.quads[e]``.

    Raises
    ------
    PanelModelError
        If the mesh has no element, ``n_modes < 1`` or ``cell_mass_as`` is unknown.
    MissingExtraError
        If pyNastran is not installed.
    OutputPathError
        If ``path`` is not a regular file (a folder, a device, ...) or cannot be written.
    """
    problems = []
    if cell_mass_as not in CELL_MASS_OPTIONS:
        problems.append(Problem("cell_mass_as", f"one of {', '.join(CELL_MASS_OPTIONS)}", repr(cell_mass_as)))
    if isinstance(n_modes, bool) or not isinstance(n_modes, (int, np.integer)) or n_modes < 1:
        problems.append(Problem("n_modes", "an integer >= 1", repr(n_modes)))
    if problems:
        raise PanelModelError(problems)
    mesh = panel_mesh(geometry, n_length=n_length, n_width=n_width)
    BDF, CaseControlDeck, _ = _pynastran()

    model = BDF(debug=None, log=_PYNASTRAN_LOG)
    model.sol = 103
    model.executive_control_lines = ["SOL 103", "CEND"]
    model.sol_iline = 0
    name = title or geometry.name or laminate.name or "panel"
    model.case_control_deck = CaseControlDeck([
        f"TITLE = {name} cantilever modes (postcapture)",
        "ECHO = NONE",
        "SUBCASE 1",
        "  METHOD = 1",
        "  SPC = 1",
        "  DISPLACEMENT(PLOT) = ALL",
        "BEGIN BULK",
    ], log=_PYNASTRAN_LOG)
    model.add_param("POST", [-1], comment=" OP2 output; SI units: m, kg, s, N, Pa")
    model.add_param("WTMASS", [1.0])

    plies = laminate.plies if cell_mass_as == "nsm" else laminate.effective_plies()
    mids: dict[tuple, int] = {}  # one MAT8 per distinct material (the cell-loaded top ply gets its own)
    for ply in plies:
        m = ply.material
        if _material_key(m) not in mids:
            mids[_material_key(m)] = len(mids) + 1
            model.add_mat8(mids[_material_key(m)], m.e1, m.e2, m.nu12, g12=m.g12, g1z=m.g13, g2z=m.g23,
                           rho=m.rho, comment=f" {m.name or 'material'} rho = {m.rho:.6g} kg/m^3")
    nsm = laminate.cell_mass if cell_mass_as == "nsm" else 0.0
    note = f" {name}: plies bottom to top, cells {laminate.cell_mass:g} kg/m^2 as {cell_mass_as}"
    model.add_pcomp(1, [mids[_material_key(p.material)] for p in plies], [p.thickness for p in plies],
                    thetas=[p.angle_deg for p in plies], nsm=nsm, lam=None, z0=-0.5 * laminate.thickness,
                    comment=note)
    for i, xyz in enumerate(mesh.nodes):
        model.add_grid(i + 1, [float(c) for c in xyz])
    for e, quad in enumerate(mesh.quads):
        model.add_cquad4(e + 1, 1, [int(n) + 1 for n in quad], theta_mcid=0.0)
    model.add_spc1(1, "123456", [int(n) + 1 for n in mesh.root_nodes], comment=" root clamp")
    model.add_eigrl(1, nd=int(n_modes), norm="MASS")
    write_atomic(path, lambda tmp: model.write_bdf(tmp, size=16, is_double=False,
                                                   enddata=True))  # MYSTRAN stops without ENDDATA
    logger.info("wrote %s: %d GRID, %d CQUAD4, %d MAT8, SOL 103", os.fspath(path), mesh.n_nodes,
                mesh.n_elements, len(mids))
    return mesh


def _material_key(m) -> tuple:
    return (m.e1, m.e2, m.nu12, m.g12, m.g13, m.g23, m.rho)


@dataclass(frozen=True)
class Op2Modes:
    """Real modes read from an OP2 file.

    Attributes
    ----------
    frequencies_hz : ndarray, shape (n_modes,)
        ``sqrt(|eigenvalue|) / (2 pi)`` (Hz).
    eigenvalues : ndarray, shape (n_modes,)
        ``omega^2`` (rad^2/s^2).
    node_ids : ndarray of int, shape (n_nodes,)
        GRID ids, in the order of ``shapes``.
    shapes : ndarray, shape (n_nodes, 6, n_modes)
        Eigenvectors ``(T1, T2, T3, R1, R2, R3)`` in the output frame of each GRID, normalised as the
        run's EIGRL asked (``MASS`` in files from `write_bdf`).
    path : str
        The file read.
    """

    frequencies_hz: np.ndarray
    eigenvalues: np.ndarray
    node_ids: np.ndarray
    shapes: np.ndarray
    path: str

    def to_panel_modes(self, mesh: PanelMesh) -> PanelModes:
        """Return the same modes on a `PanelMesh` (GRID ``i + 1`` is node ``i``, as `write_bdf` numbers them).

        Raises
        ------
        NastranError
            If the OP2 nodes are not the mesh's.
        """
        expected = np.arange(1, mesh.n_nodes + 1)
        order = np.argsort(self.node_ids)
        if not np.array_equal(self.node_ids[order], expected):
            raise NastranError(f"its {self.node_ids.size} GRIDs are not the {mesh.n_nodes} nodes "
                               f"1..{mesh.n_nodes} of the {mesh.n_length} x {mesh.n_width} mesh", self.path)
        return PanelModes(mesh=mesh, frequencies_hz=self.frequencies_hz, shapes=self.shapes[order],
                          participation=None, rigid_mass=None, total_mass=float("nan"))


def read_op2_modes(path, *, subcase: int | None = None) -> Op2Modes:
    """Read real eigenvalues and eigenvectors from a Nastran OP2 file (SOL 103).

    Parameters
    ----------
    path : str or os.PathLike
        The OP2 file.
    subcase : int, optional
        Subcase to read; needed only when the file holds eigenvectors of several subcases.

    Returns
    -------
    Op2Modes

    Raises
    ------
    NastranError
        If the file does not exist, pyNastran cannot read it, it has no real eigenvectors, or the
        subcase is missing or ambiguous.
    MissingExtraError
        If pyNastran is not installed.
    """
    fname = os.fspath(path)
    if not os.path.isfile(fname):
        raise NastranError("no such file", fname)
    _, _, OP2 = _pynastran()
    op2 = OP2(debug=False, log=_PYNASTRAN_LOG)
    try:
        with warnings.catch_warnings():
            # pyNastran 1.3.4 builds a np.chararray per table: deprecated in numpy 2, still present in 2.4
            warnings.filterwarnings("ignore", message=".*np.chararray.*", category=DeprecationWarning)
            op2.read_op2(fname, build_dataframe=False)
    except Exception as exc:  # pyNastran raises many types for a malformed file
        raise NastranError(f"pyNastran cannot read it as an OP2 ({type(exc).__name__}: {exc})",
                           fname) from exc
    tables = {k: v for k, v in op2.eigenvectors.items() if getattr(v, "is_real", False)}
    if not tables:
        found = sorted(k for k in op2.get_table_types() if _has_results(op2, k)) or ["no result tables"]
        raise NastranError("no real eigenvectors in it (run SOL 103 with DISPLACEMENT(PLOT) = ALL); "
                           f"it holds: {', '.join(found)}", fname)
    if subcase is None:
        if len(tables) > 1:
            raise NastranError(f"eigenvectors of several subcases {sorted(tables)}: choose one with "
                               "`subcase`", fname)
        vec = next(iter(tables.values()))
    else:
        match = [v for k, v in tables.items() if (k[0] if isinstance(k, tuple) else k) == subcase]
        if not match:
            raise NastranError(f"no eigenvectors for subcase {subcase}; found {sorted(tables)}", fname)
        vec = match[0]
    grids = vec.node_gridtype[:, 1] == 1  # GRID points only (no SPOINT/EPOINT)
    data = np.asarray(vec.data, dtype=float)[:, grids, :]  # (n_modes, n_nodes, 6)
    eig = np.asarray(getattr(vec, "eigns", []), dtype=float)
    if eig.size != data.shape[0]:
        eig = _eigenvalues_from_lama(op2, data.shape[0], fname)
    return Op2Modes(
        frequencies_hz=np.sqrt(np.abs(eig)) / (2.0 * np.pi),
        eigenvalues=eig,
        node_ids=np.asarray(vec.node_gridtype[grids, 0], dtype=int),
        shapes=np.transpose(data, (1, 2, 0)).copy(),
        path=fname,
    )


def _has_results(op2, table_type: str) -> bool:
    try:
        return bool(op2.get_result(table_type))
    except Exception:  # some pyNastran result groups are not dictionaries
        return False


def _eigenvalues_from_lama(op2, n_modes: int, fname: str) -> np.ndarray:
    """Return the eigenvalues from the LAMA table when the eigenvector table does not carry them."""
    for table in op2.eigenvalues.values():
        values = np.asarray(table.eigenvalues, dtype=float)
        if values.size >= n_modes:
            return values[:n_modes]
    raise NastranError(f"no eigenvalues for its {n_modes} eigenvectors", fname)
