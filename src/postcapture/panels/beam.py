"""The uniform beam equivalent to a laminate strip, for lumped-chain models of the panel.

The lumped chain of rigid segments and hinge springs needs a bending stiffness ``EI(s)`` and a mass per
unit length; for a uniform panel they follow from the laminate and the width. The narrow-strip value
``EI = width / d11`` (``d = inv(ABD)``, free anticlastic curvature) is the one a slender cantilever sees
away from its root; ``width * D11`` (cylindrical bending) bounds it from above.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from postcapture.core.errors import PanelModelError, Problem
from postcapture.panels.laminate import Laminate

__all__ = ["EquivalentBeam", "equivalent_beam"]


@dataclass(frozen=True, slots=True)
class EquivalentBeam:
    """Uniform beam equivalent to a laminate strip of a given width.

    Attributes
    ----------
    bending_stiffness : float
        Out-of-plane bending stiffness ``EI = width / d11`` with ``d = inv([[A, B], [B, D]])[3:, 3:]``,
        the narrow-strip value (free anticlastic curvature) (N m^2).
    plate_bending_stiffness : float
        ``width * D11``, the cylindrical-bending (wide plate) value (N m^2); the FEM lies between the two.
    torsional_stiffness : float
        Saint-Venant torsional stiffness of the thin strip ``GJ = 4 width / d66`` (N m^2).
    mass_per_length : float
        ``areal_mass * width`` (kg/m).
    torsional_inertia_per_length : float
        Mass moment of inertia per unit length about the strip's axis, ``areal_mass * width^3 / 12`` (kg m).
    width : float
        Strip width (m).
    """

    bending_stiffness: float
    plate_bending_stiffness: float
    torsional_stiffness: float
    mass_per_length: float
    torsional_inertia_per_length: float
    width: float

    def bending_stiffness_at(self, stations) -> np.ndarray:
        """``EI(s)`` at stations ``s`` along the panel (m), shape of ``stations`` (N m^2); uniform here."""
        return np.full(np.shape(stations), self.bending_stiffness)

    def mass_per_length_at(self, stations) -> np.ndarray:
        """Mass per unit length at stations ``s`` (m), shape of ``stations`` (kg/m); uniform here."""
        return np.full(np.shape(stations), self.mass_per_length)


def equivalent_beam(laminate: Laminate, width: float) -> EquivalentBeam:
    """Compute the equivalent beam properties of a laminate strip of width ``width`` (m).

    Parameters
    ----------
    laminate : Laminate
        The panel section.
    width : float
        Strip width (m), > 0.

    Returns
    -------
    EquivalentBeam

    Raises
    ------
    PanelModelError
        If the width is not positive.
    """
    if isinstance(width, bool) or not isinstance(width, (int, float, np.number)) or not math.isfinite(width) \
            or width <= 0.0:
        raise PanelModelError([Problem("width", "a finite width > 0 m", repr(width))])
    compliance = np.linalg.inv(laminate.abd_matrix())
    _, _, d = laminate.abd()
    m = laminate.areal_mass
    return EquivalentBeam(
        bending_stiffness=float(width / compliance[3, 3]),
        plate_bending_stiffness=float(width * d[0, 0]),
        torsional_stiffness=float(4.0 * width / compliance[5, 5]),
        mass_per_length=float(m * width),
        torsional_inertia_per_length=float(m * width**3 / 12.0),
        width=float(width),
    )
