"""Rigid-body mass properties: panel segments, and the hub left when panels are taken out of a whole body."""

from __future__ import annotations

import numpy as np

from postcapture.config.schema import Panel
from postcapture.core.errors import Problem, ScenarioError

__all__ = ["MassProperties", "segment_properties", "panel_properties", "hub_properties", "parallel_axis"]


class MassProperties:
    """Mass (kg), centre of mass (m) and inertia about the centre of mass (kg m^2) in one frame."""

    __slots__ = ("mass", "com", "inertia")

    def __init__(self, mass: float, com, inertia):
        self.mass = float(mass)
        self.com = np.asarray(com, dtype=float).reshape(3)
        self.inertia = np.asarray(inertia, dtype=float).reshape(3, 3)

    def transformed(self, R, p) -> "MassProperties":
        """The same body seen from a parent frame where this frame has rotation R and origin p."""
        return MassProperties(self.mass, R @ self.com + p, R @ self.inertia @ R.T)

    def about_origin(self) -> np.ndarray:
        """Inertia about the frame origin (parallel-axis theorem)."""
        return self.inertia + parallel_axis(self.mass, self.com)


def parallel_axis(mass: float, r) -> np.ndarray:
    """Inertia of a point mass ``mass`` at ``r`` about the origin: ``m (|r|^2 I - r r^T)``."""
    r = np.asarray(r, dtype=float)
    return mass * (r @ r * np.eye(3) - np.outer(r, r))


def segment_properties(panel: Panel) -> MassProperties:
    """One rigid segment in its hinge frame (x along the panel, y across, z normal): a thin plate."""
    n = panel.segments
    l = panel.length / n
    m = panel.mass / n
    w = panel.width
    inertia = np.diag([m * w * w / 12.0, m * l * l / 12.0, m * (l * l + w * w) / 12.0])
    return MassProperties(m, [0.5 * l, 0.0, 0.0], inertia)


def panel_properties(panel: Panel) -> MassProperties:
    """The whole undeformed panel in its root frame P."""
    L, w, m = panel.length, panel.width, panel.mass
    # N thin plates end to end are one thin plate of length L.
    inertia = np.diag([m * w * w / 12.0, m * L * L / 12.0, m * (L * L + w * w) / 12.0])
    return MassProperties(m, [0.5 * L, 0.0, 0.0], inertia)


def hub_properties(
    mass: float, inertia, panels: list[tuple[np.ndarray, np.ndarray, MassProperties]], where: str
) -> MassProperties:
    """The rigid hub of a body whose whole-body properties include its panels.

    Parameters
    ----------
    mass, inertia
        Whole-body mass (kg) and inertia about the whole-body centre of mass (kg m^2), which is the
        origin of the body frame.
    panels : list of (R, p, MassProperties)
        Each panel's undeformed properties in its root frame, with the root frame's rotation R and
        origin p in the body frame.
    where : str
        Scenario path used in error messages (``"target"``).
    """
    total_I = np.asarray(inertia, dtype=float)
    m_hub = float(mass)
    first_moment = np.zeros(3)
    I_panels = np.zeros((3, 3))
    for R, p, props in panels:
        body = props.transformed(R, p)
        m_hub -= body.mass
        first_moment += body.mass * body.com
        I_panels += body.about_origin()
    if m_hub <= 0.0:
        raise ScenarioError([Problem(f"{where}.mass", "more than the panels' mass", f"{mass} kg")])
    c_hub = -first_moment / m_hub
    I_hub = total_I - I_panels - parallel_axis(m_hub, c_hub)
    eig = np.linalg.eigvalsh(0.5 * (I_hub + I_hub.T))
    if eig[0] <= 0.0 or eig[0] + eig[1] < eig[2] * (1 - 1e-9):
        raise ScenarioError(
            [
                Problem(
                    f"{where}.inertia",
                    "a whole-body inertia that still leaves a physical hub once the panels are removed",
                    f"hub principal moments {np.round(eig, 3).tolist()}",
                )
            ]
        )
    return MassProperties(m_hub, c_hub, 0.5 * (I_hub + I_hub.T))
