"""Composite solar panels: laminate, shell FEM modes, transient, Kirchhoff check, Nastran interchange.

Modules: ``laminate`` (classical lamination theory, sandwich with honeycomb core), ``beam`` (equivalent beam),
``builtin`` (the Envisat and chaser panels and why their plies), ``mesh`` (geometry, structured mesh),
``fem`` (pyfe3d Quad4 shell modal analysis), ``modes`` (classification, effective masses, centreline
sampling), ``kirchhoff`` (independent scikit-fem plate), ``transient`` (tip response by modal
superposition), ``nastran`` (SOL 103 bulk data out, OP2 modes in, with pyNastran), ``lumped`` (the
multibody model's panel chain on a fixed base, linearised), ``identify`` (weighted Gauss-Newton fit of
the hinge stiffnesses, torsion spring), ``sweep`` (tip sine sweep, amplitude spectra, interpolated peak),
``calibration`` and ``calibrate`` (the whole calibration in one call, its tables, JSON and TOML).

pyfe3d and scikit-fem are imported when a model is solved, pyNastran only by the ``nastran`` functions;
all three come with the ``panels`` extra.
"""

from postcapture.panels.beam import EquivalentBeam, equivalent_beam
from postcapture.panels.builtin import builtin_geometry, builtin_laminate, builtin_panel
from postcapture.panels.calibrate import calibrate, load_panel_file
from postcapture.panels.calibration import CalibrationResult, CalibrationRun
from postcapture.panels.fem import solve_modes
from postcapture.panels.identify import (
    IdentificationResult,
    ModalTarget,
    identify_stiffness,
    torsion_stiffness,
)
from postcapture.panels.kirchhoff import KirchhoffModes, solve_modes_kirchhoff
from postcapture.panels.laminate import Laminate, OrthotropicMaterial, Ply
from postcapture.panels.lumped import LumpedChain, LumpedModes, chain_panel, lumped_modes
from postcapture.panels.mesh import PanelGeometry, PanelMesh, panel_mesh
from postcapture.panels.modes import PanelModes
from postcapture.panels.nastran import Op2Modes, read_op2_modes, write_bdf
from postcapture.panels.sweep import SweepSpec, amplitude_spectrum, spectral_peak
from postcapture.panels.transient import tip_response_modal

__all__ = [
    "OrthotropicMaterial",
    "Ply",
    "Laminate",
    "EquivalentBeam",
    "equivalent_beam",
    "builtin_laminate",
    "builtin_geometry",
    "builtin_panel",
    "PanelGeometry",
    "PanelMesh",
    "panel_mesh",
    "PanelModes",
    "solve_modes",
    "KirchhoffModes",
    "solve_modes_kirchhoff",
    "tip_response_modal",
    "write_bdf",
    "Op2Modes",
    "read_op2_modes",
    "chain_panel",
    "LumpedChain",
    "LumpedModes",
    "lumped_modes",
    "ModalTarget",
    "IdentificationResult",
    "identify_stiffness",
    "torsion_stiffness",
    "SweepSpec",
    "amplitude_spectrum",
    "spectral_peak",
    "CalibrationRun",
    "CalibrationResult",
    "calibrate",
    "load_panel_file",
]
