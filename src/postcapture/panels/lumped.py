"""The lumped panel chain on a fixed base, linearised: frequencies and mode shapes at the joints.

The chain is the one the multibody model simulates, built by
`postcapture.dynamics.assembly.assemble_panel_chain` and wrapped in a
`postcapture.dynamics.system.System`: a root torsion hinge about the panel's x axis, then N bending
hinges about y, each carrying a thin rigid plate of mass ``m / N`` and length ``l = L / N``, with
linear springs (the system's spring set). Nothing here rebuilds that model: the mass matrix comes from
the compiled core that simulates it (`postcapture.dynamics.core.CompiledPlant.mass_matrix`), the
stiffness from its spring rows, so what is identified is exactly what is simulated.

Stations and signs (panel frame P: x along the panel from the root, z along the normal)
-------------------------------------------------------------------------------------
Hinge ``j`` (``j = 0..N-1``) sits at ``s_j = j l``; the tip is ``s_N = L``. A hinge angle ``theta_j``
about +y turns +x towards -z, so for small angles segment ``i`` has the slope
``dw/dx = -sum_{j <= i} theta_j`` and ``w(s) = -sum_j theta_j max(0, s - s_j)``, the convention of
the FEM's `postcapture.panels.modes.PanelModes.centreline` (``dw/dx = -r_y``). At a hinge the slope
jumps; `LumpedModes.centreline` returns the mean of both sides there. Mode shapes are mass-normalised
(``phi^T M phi = 1``, so ``w`` is in m/sqrt(kg) like the FEM's) and signed like the FEM's: the largest
out-of-plane displacement of a bending mode at the stations is positive, a torsion mode turns +y
towards +z.

Bending and torsion are decoupled at rest (the plates are symmetric about ``y = 0``): a mode is
``"torsion"`` when the torsion spring holds most of its strain energy, otherwise ``"bending"``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.linalg as sla
from pydantic import ValidationError

from postcapture.config.loader import problems_from_validation
from postcapture.config.schema import Panel
from postcapture.core.errors import PanelModelError, Problem
from postcapture.dynamics.assembly import assemble_panel_chain
from postcapture.dynamics.core import CompiledPlant
from postcapture.dynamics.modes import structural_modes
from postcapture.dynamics.system import System

__all__ = ["LUMPED_KINDS", "chain_panel", "centreline_maps", "LumpedChain", "LumpedModes", "lumped_modes"]

LUMPED_KINDS = ("bending", "torsion")


def chain_panel(name: str, *, length: float, width: float, mass: float, bending_stiffness,
                torsion_stiffness: float, damping_beta: float = 0.0) -> Panel:
    """Build and validate the scenario `Panel` of a chain (segments = number of bending stiffnesses).

    Parameters
    ----------
    name : str
        Panel name (frames ``<name>_root`` and ``<name>_tip``).
    length, width : float
        Panel length and width (m).
    mass : float
        Panel mass (kg).
    bending_stiffness : array_like, shape (N,)
        Hinge stiffnesses from root to tip (N m/rad).
    torsion_stiffness : float
        Root torsion hinge stiffness (N m/rad).
    damping_beta : float, optional
        Stiffness-proportional damping ``d = beta k`` (s). Default 0.

    Returns
    -------
    Panel

    Raises
    ------
    PanelModelError
        With every schema problem (non-positive values, ...).
    """
    k = tuple(float(x) for x in np.atleast_1d(np.asarray(bending_stiffness, dtype=float)))
    try:
        return Panel(name=name, length=length, width=width, mass=mass, segments=len(k), bending_stiffness=k,
                     torsion_stiffness=torsion_stiffness, damping_beta=damping_beta)
    except ValidationError as exc:
        raise PanelModelError(problems_from_validation(exc), source=name) from None


def centreline_maps(length: float, segments: int, stations) -> tuple[np.ndarray, np.ndarray]:
    """Linear maps from the bending hinge angles to ``w`` and ``dw/dx`` at stations along the chain.

    Parameters
    ----------
    length : float
        Panel length ``L`` (m).
    segments : int
        Number of segments ``N``.
    stations : array_like, shape (n_stations,)
        Distances from the root in ``[0, L]`` (m).

    Returns
    -------
    w_map : ndarray, shape (n_stations, N)
        ``w = w_map @ theta`` (m/rad).
    slope_map : ndarray, shape (n_stations, N)
        ``dw/dx = slope_map @ theta`` (1/rad); the mean of both sides at a hinge.

    Raises
    ------
    PanelModelError
        If a station lies outside the panel.
    """
    s = np.atleast_1d(np.asarray(stations, dtype=float))
    bad = (s < -1e-12 * length) | (s > length * (1 + 1e-12)) | ~np.isfinite(s)
    if np.any(bad):
        raise PanelModelError([Problem("stations", f"values in [0, {length:g}] m",
                                       repr(s[bad][:3].tolist()))])
    hinges = length / segments * np.arange(segments)
    lever = s[:, None] - hinges[None, :]
    tol = 1e-12 * length
    step = np.where(lever > tol, 1.0, np.where(lever < -tol, 0.0, 0.5))
    return -np.clip(lever, 0.0, None), -step


@dataclass(frozen=True)
class LumpedModes:
    """Undamped modes of the linearised chain on a fixed base.

    Attributes
    ----------
    length : float
        Panel length (m).
    segments : int
        Number of segments ``N``.
    frequencies_hz : ndarray, shape (n_modes,)
        Natural frequencies, ascending (Hz); ``n_modes = N + 1``.
    damping_ratios : ndarray, shape (n_modes,)
        Modal damping ratios of the springs' dampers (-).
    shapes : ndarray, shape (N + 1, n_modes)
        Mass-normalised shapes in joint coordinates (rad/(m sqrt(kg))): the torsion hinge, then the
        bending hinges root to tip (the chain's velocity order).
    kinds : tuple of str
        ``"bending"`` or ``"torsion"`` for each mode.
    torsion_index : int
        Row of the torsion hinge in ``shapes``.
    bending_index : ndarray of int, shape (N,)
        Rows of the bending hinges in ``shapes``, root to tip.
    """

    length: float
    segments: int
    frequencies_hz: np.ndarray
    damping_ratios: np.ndarray
    shapes: np.ndarray
    kinds: tuple[str, ...]
    torsion_index: int
    bending_index: np.ndarray

    @property
    def n_modes(self) -> int:
        """Number of modes (``N + 1``)."""
        return self.frequencies_hz.size

    @property
    def joint_stations(self) -> np.ndarray:
        """Hinge stations outboard of the root and the tip, ``s_j = j L / N``, j = 1..N, shape (N,) (m)."""
        return self.length / self.segments * np.arange(1, self.segments + 1)

    @property
    def midpoints(self) -> np.ndarray:
        """Segment midpoints ``(j + 1/2) L / N``, j = 0..N-1, shape (N,) (m)."""
        return self.length / self.segments * (np.arange(self.segments) + 0.5)

    def indices(self, kind: str) -> np.ndarray:
        """Return the indices of the modes of one kind (``"bending"`` or ``"torsion"``), ascending."""
        if kind not in LUMPED_KINDS:
            raise PanelModelError([Problem("kind", f"one of {', '.join(LUMPED_KINDS)}", repr(kind))])
        return np.flatnonzero(np.asarray(self.kinds) == kind)

    def frequency(self, kind: str, order: int = 1) -> float:
        """Return the frequency (Hz) of the ``order``-th (1-based) mode of a kind.

        Raises
        ------
        PanelModelError
            If the chain has fewer than ``order`` modes of that kind.
        """
        idx = self.indices(kind)
        if not 1 <= order <= idx.size:
            raise PanelModelError([Problem(f"{kind} mode {order}", f"at most {idx.size}", str(order))])
        return float(self.frequencies_hz[idx[order - 1]])

    def centreline(self, stations=None, modes=None) -> tuple[np.ndarray, np.ndarray]:
        """Sample the out-of-plane displacement and slope along the chain's centreline.

        Parameters
        ----------
        stations : array_like, shape (n_stations,), optional
            Distances from the root in ``[0, L]`` (m); default `joint_stations`.
        modes : array_like of int, optional
            Mode indices; default all.

        Returns
        -------
        w : ndarray, shape (n_stations, n_selected)
            Displacement along z (m/sqrt(kg)).
        slope : ndarray, shape (n_stations, n_selected)
            ``dw/dx`` (1/sqrt(kg)); the mean of both sides at a hinge.

        Raises
        ------
        PanelModelError
            If a station lies outside the panel.
        """
        s = self.joint_stations if stations is None else stations
        sel = np.arange(self.n_modes) if modes is None else np.atleast_1d(np.asarray(modes, dtype=int))
        w_map, slope_map = centreline_maps(self.length, self.segments, s)
        theta = self.shapes[self.bending_index][:, sel]
        return w_map @ theta, slope_map @ theta


class LumpedChain:
    """The panel chain of the multibody model on a fixed base, for fast repeated modal analysis.

    Parameters
    ----------
    panel : Panel
        The panel (its mass, length, width and number of segments fix the mass matrix; the
        stiffnesses are only a default for `modes`).

    Attributes
    ----------
    panel : Panel
    system : System
        The chain as simulated (``System(assemble_panel_chain(panel))``).
    mass_matrix : ndarray, shape (N + 1, N + 1)
        Joint-space mass matrix at rest, from the compiled core (kg m^2).
    torsion_index : int
        Velocity index of the torsion hinge.
    bending_index : ndarray of int, shape (N,)
        Velocity indices of the bending hinges, root to tip.

    Raises
    ------
    PanelModelError
        If the chain's torsion and bending coordinates are coupled at rest, or a spring acts on more
        than one hinge angle (the identification relies on neither happening).
    """

    def __init__(self, panel: Panel):
        self.panel = panel
        self.system = System(assemble_panel_chain(panel))
        sysm = self.system
        lay = sysm.layout.panels[0]
        self.torsion_index = int(lay.torsion_v)
        self.bending_index = np.asarray(lay.bending_v, dtype=int)
        self.mass_matrix = CompiledPlant(sysm).mass_matrix(sysm.assembly.q_rest)
        coupling = np.max(np.abs(self.mass_matrix[self.torsion_index, self.bending_index]))
        if coupling > 1e-12 * np.max(np.abs(self.mass_matrix)):
            raise PanelModelError([Problem("chain", "torsion decoupled from bending at rest",
                                           f"a coupling inertia of {coupling:.3g} kg m^2")],
                                  source=panel.name)
        # spring j acts on one coordinate: its row of the spring matrix (n_root = 0, so e == v)
        rows = sysm.assembly.springs.matrix(sysm.n_e)
        self._spring_rows = rows
        self._bending_springs = np.array([int(np.flatnonzero(rows[:, i])[0]) for i in self.bending_index])
        self._torsion_spring = int(np.flatnonzero(rows[:, self.torsion_index])[0])
        own = rows[np.ix_(self._bending_springs, self.bending_index)]
        if not (np.array_equal(own, np.eye(self.bending_index.size))
                and np.count_nonzero(rows[self._bending_springs]) == self.bending_index.size):
            raise PanelModelError([Problem("chain", "one spring per hinge angle", "coupled spring rows")],
                                  source=panel.name)
        b = self.bending_index
        self._m_bb = self.mass_matrix[np.ix_(b, b)]

    @property
    def segments(self) -> int:
        """Number of segments ``N``."""
        return self.panel.segments

    @property
    def torsion_inertia(self) -> float:
        """Moment of inertia of the chain about its torsion axis at rest (kg m^2), from the mass matrix."""
        return float(self.mass_matrix[self.torsion_index, self.torsion_index])

    def stiffness_matrix(self, bending_stiffness, torsion_stiffness: float) -> np.ndarray:
        """Joint stiffness matrix ``A^T diag(k) A`` of the chain's springs, shape (N + 1, N + 1) (N m/rad)."""
        k = np.zeros(self._spring_rows.shape[0])
        k[self._bending_springs] = np.asarray(bending_stiffness, dtype=float)
        k[self._torsion_spring] = float(torsion_stiffness)
        return self._spring_rows.T @ (k[:, None] * self._spring_rows)

    def bending_eigen(self, bending_stiffness) -> tuple[np.ndarray, np.ndarray]:
        """Bending eigenpairs for given hinge stiffnesses, without rebuilding the model.

        Parameters
        ----------
        bending_stiffness : array_like, shape (N,)
            Hinge stiffnesses, root to tip (N m/rad).

        Returns
        -------
        omega2 : ndarray, shape (N,)
            Squared circular frequencies, ascending (rad^2/s^2).
        phi : ndarray, shape (N, N)
            Mass-normalised shapes in the bending hinge angles, root to tip (rad/(m sqrt(kg))).
        """
        k_full = self.stiffness_matrix(bending_stiffness, 1.0)
        b = self.bending_index
        return sla.eigh(k_full[np.ix_(b, b)], self._m_bb)

    def with_stiffness(self, bending_stiffness=None, torsion_stiffness: float | None = None,
                       damping_beta: float | None = None) -> Panel:
        """Return the chain's panel with other stiffnesses or damping (a new, validated `Panel`).

        Parameters
        ----------
        bending_stiffness : array_like, shape (N,), optional
            Hinge stiffnesses, root to tip (N m/rad); default the panel's.
        torsion_stiffness : float, optional
            Torsion hinge stiffness (N m/rad); default the panel's.
        damping_beta : float, optional
            Stiffness-proportional damping (s); default the panel's.

        Returns
        -------
        Panel
        """
        p = self.panel
        k = p.bending_stiffness if bending_stiffness is None else bending_stiffness
        kt = p.torsion_stiffness if torsion_stiffness is None else torsion_stiffness
        beta = p.damping_beta if damping_beta is None else damping_beta
        return chain_panel(p.name, length=p.length, width=p.width, mass=p.mass, bending_stiffness=k,
                           torsion_stiffness=kt, damping_beta=beta)


def lumped_modes(panel: Panel) -> LumpedModes:
    """Compute the modes of the panel chain on a fixed base, linearised at rest.

    Parameters
    ----------
    panel : Panel
        The panel (length, width, mass, segments, stiffnesses, damping).

    Returns
    -------
    LumpedModes
        ``N + 1`` modes from `postcapture.dynamics.modes.structural_modes` of
        ``System(assemble_panel_chain(panel))``, classified by the spring group holding most of the
        strain energy, signed as in the module text.
    """
    sysm = System(assemble_panel_chain(panel))
    lay = sysm.layout.panels[0]
    bend = np.asarray(lay.bending_v, dtype=int)
    tors = int(lay.torsion_v)
    found = structural_modes(sysm)
    shapes = np.column_stack([m.shape for m in found])
    kinds = tuple("torsion" if m.dominant == f"{panel.name} torsion" else "bending" for m in found)
    w_map, _ = centreline_maps(panel.length, panel.segments, panel.length / panel.segments
                               * np.arange(1, panel.segments + 1))
    w = w_map @ shapes[bend]
    for j, kind in enumerate(kinds):
        ref = shapes[tors, j] if kind == "torsion" else w[np.argmax(np.abs(w[:, j])), j]
        if ref < 0.0:
            shapes[:, j] *= -1.0
    return LumpedModes(
        length=float(panel.length),
        segments=int(panel.segments),
        frequencies_hz=np.array([m.frequency_hz for m in found]),
        damping_ratios=np.array([m.damping_ratio for m in found]),
        shapes=shapes,
        kinds=kinds,
        torsion_index=tors,
        bending_index=bend,
    )
