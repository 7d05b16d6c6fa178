"""Built-in panel sections: Envisat's solar wing and the chaser's panel.

The reference gives no laminate data, only the layout (aluminium honeycomb core sandwich with
uni-directional carbon-fibre faces, solar cells as a denser upper ply, 8 mm core for Envisat, 2 mm for
the chaser) and the result (first bending mode of the Envisat wing at 0.0799 Hz). The plies below are
an assumption chosen to be plausible and to reproduce that result; they are not Envisat data.

Materials (representative values, not from a datasheet of the actual hardware)
------------------------------------------------------------------------------
* ``CFRP_UD``: T300/5208 graphite/epoxy, the classic textbook unidirectional ply (Tsai and Hahn,
  *Introduction to Composite Materials*, 1980): E1 = 181 GPa, E2 = 10.3 GPa, nu12 = 0.28,
  G12 = 7.17 GPa, rho = 1600 kg/m^3; G13 = G12 and G23 = 3.4 GPa (about E2 / (2 (1 + 0.5)), assumed).
* ``AL_HONEYCOMB``: 5052 aluminium honeycomb of 3.1 lb/ft^3 (49.7 kg/m^3), ribbon-direction (L) shear
  modulus 483 MPa and transverse (W) 214 MPa, orders of magnitude of manufacturers' tables for
  1/8 in cells; its in-plane moduli are set to a negligible 1 MPa (a core carries no membrane load).
  The ribbon (L) direction is laid along the panel length.

Envisat wing: 14 m x 5 m, 8 mm core
-----------------------------------
Each face is ``[0, 0, 0, 0, 90, 90]`` from the outside in (0.125 mm plies: 0.5 mm of 0 deg fibres along
the length for bending, 0.25 mm at 90 deg for the chordwise stiffness and against splitting), the
sandwich is symmetric so ``B = 0``, and a cross-ply has no bending-twisting coupling (``D16 = D26 = 0``),
so bending and torsion decouple as in the reference's linearised model. The cell assembly (cells, cover
glass, adhesive, harness) is 2.0 kg/m^2, carried by the top ply.

Why about 0.08 Hz: ``D11 = 3774 N m``, so ``EI = width / d11 = 18.87 kN m^2``; the areal mass is
``2 x 0.75 mm x 1600 + 8 mm x 49.7 + 2.0 = 4.80 kg/m^2`` (335.8 kg, inside the 300-350 kg of
physical-data.md), i.e. ``m = 23.98 kg/m``; Euler-Bernoulli gives
``f1 = 1.8751^2 / (2 pi) sqrt(EI / (m L^4)) = 0.0800 Hz``. The shell model adds the core's shear
flexibility and the clamp's restraint of anticlastic bending at the root, both well under 1 % here
(the 20 x 60 FEM gives 0.0800 Hz, see the tests). Its first torsion mode is at 0.21 Hz; the reference's
torsion spring (621.6 N m/rad on a rigid wing of 700 kg m^2 about its axis) implies about 0.15 Hz, so
the reference's (unknown) laminate was softer in torsion than this one. Torsion is identified on its
own frequency, so this does not affect the bending calibration.

Chaser panel: 5 m x 2 m, 2 mm core
----------------------------------
Faces ``[0, 90]`` (0.125 mm each), same cells: areal mass 2.90 kg/m^2, 29.0 kg ("about 30 kg").
``EI = 134 N m^2`` gives a first bending mode at 0.108 Hz (torsion 0.28 Hz).
"""

from __future__ import annotations

from postcapture.core.errors import PanelModelError, Problem
from postcapture.panels.laminate import Laminate, OrthotropicMaterial, Ply
from postcapture.panels.mesh import PanelGeometry

__all__ = ["CFRP_UD", "AL_HONEYCOMB", "PLY_THICKNESS", "CELL_MASS", "BUILTIN_PANELS", "builtin_laminate",
           "builtin_geometry", "builtin_panel"]

CFRP_UD = OrthotropicMaterial(e1=181e9, e2=10.3e9, nu12=0.28, g12=7.17e9, g13=7.17e9, g23=3.4e9, rho=1600.0,
                              name="CFRP_UD")
AL_HONEYCOMB = OrthotropicMaterial(e1=1e6, e2=1e6, nu12=0.3, g12=0.4e6, g13=483e6, g23=214e6, rho=49.7,
                                   name="AL_HONEYCOMB")
PLY_THICKNESS = 0.125e-3
"""Thickness of one cured UD ply (m)."""
CELL_MASS = 2.0
"""Areal mass of the solar-cell assembly on the top face (kg/m^2), an assumption."""


def _sandwich(face_angles: list[float], core: float, name: str) -> Laminate:
    """Symmetric sandwich: ``face_angles`` from the outer to the inner face ply, core, mirrored face."""
    bottom = [Ply(PLY_THICKNESS, a, CFRP_UD) for a in face_angles]
    top = [Ply(PLY_THICKNESS, a, CFRP_UD) for a in reversed(face_angles)]
    return Laminate(tuple(bottom + [Ply(core, 0.0, AL_HONEYCOMB)] + top), cell_mass=CELL_MASS, name=name)


BUILTIN_PANELS = {
    "envisat": (PanelGeometry(14.0, 5.0, name="envisat"), ([0.0, 0.0, 0.0, 0.0, 90.0, 90.0], 8e-3)),
    "chaser": (PanelGeometry(5.0, 2.0, name="chaser"), ([0.0, 90.0], 2e-3)),
}


def _check(name: str) -> None:
    if name not in BUILTIN_PANELS:
        raise PanelModelError([Problem("panel", f"one of {', '.join(BUILTIN_PANELS)}", repr(name))])


def builtin_laminate(name: str) -> Laminate:
    """Return the section of a built-in panel, ``"envisat"`` or ``"chaser"`` (see the module text)."""
    _check(name)
    angles, core = BUILTIN_PANELS[name][1]
    return _sandwich(angles, core, name)


def builtin_geometry(name: str) -> PanelGeometry:
    """Return the planform of a built-in panel: Envisat 14 m x 5 m, chaser 5 m x 2 m."""
    _check(name)
    return BUILTIN_PANELS[name][0]


def builtin_panel(name: str) -> tuple[PanelGeometry, Laminate]:
    """Return the geometry and section of a built-in panel, ready for `postcapture.panels.fem.solve_modes`."""
    return builtin_geometry(name), builtin_laminate(name)
