"""Composite solar panels: laminate, shell FEM modes, transient, Kirchhoff check, Nastran interchange.

Modules: ``laminate`` (classical lamination theory, sandwich with honeycomb core), ``beam`` (equivalent beam),
``builtin`` (the Envisat and chaser panels and why their plies), ``mesh`` (geometry, structured mesh),
``fem`` (pyfe3d Quad4 shell modal analysis), ``modes`` (classification, effective masses, centreline
sampling), ``kirchhoff`` (independent scikit-fem plate), ``transient`` (tip response by modal
superposition), ``nastran`` (SOL 103 bulk data out, OP2 modes in, with pyNastran).

pyfe3d and scikit-fem are imported when a model is solved, pyNastran only by the ``nastran`` functions;
all three come with the ``panels`` extra.
"""

from postcapture.panels.beam import EquivalentBeam, equivalent_beam
from postcapture.panels.builtin import builtin_geometry, builtin_laminate, builtin_panel
from postcapture.panels.fem import solve_modes
from postcapture.panels.kirchhoff import KirchhoffModes, solve_modes_kirchhoff
from postcapture.panels.laminate import Laminate, OrthotropicMaterial, Ply
from postcapture.panels.mesh import PanelGeometry, PanelMesh, panel_mesh
from postcapture.panels.modes import PanelModes
from postcapture.panels.nastran import Op2Modes, read_op2_modes, write_bdf
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
]
