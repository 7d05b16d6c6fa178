"""Continuous linearisation at any state, and modal analysis of the linearised plant.

Linearisation: with right perturbations ``q = q* (+) dq`` the error dynamics are

    d(dq)/dt = -ad_V dq + dv   (free flyer block; identity elsewhere),
    d(dv)/dt = ddq_dq dq + ddq_dv dv + Minv B du + ddq_dm dm,

so ``A = [[-ad_V, I], [ddq_dq, ddq_dv]]``, ``B = [[0], [Minv B]]``, ``E = [[0], [ddq_dm]]``; to first order
the discrete step Jacobian is ``expm(A h)``.

Modes: at rest (no motion, springs relaxed) the undamped problem ``K phi = w^2 M phi`` is symmetric;
its six zero modes are the free stack's rigid-body motions. Damping ratios are modal projections
``zeta = phi^T D phi / (2 w)`` (mass-normalised ``phi``), and each mode says what moves in it by the share of
its strain energy held by each group of springs (arm joints, each panel's bending and torsion).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.linalg as sla

from postcapture.dynamics.core import CompiledPlant
from postcapture.dynamics.liegroup import ad
from postcapture.dynamics.system import System

__all__ = ["Linearization", "linearize", "Mode", "structural_modes", "state_space_modes", "spring_groups"]


@dataclass
class Linearization:
    """``d/dt [dq; dv] = A [dq; dv] + B du + E dm`` at one state (2nv tangent coordinates)."""

    A: np.ndarray
    B: np.ndarray
    E: np.ndarray | None


def linearize(system: System, q: np.ndarray, v: np.ndarray, t: float = 0.0, u_extra=None) -> Linearization:
    """Continuous-time linearisation of the plant at ``(q, v, t)`` (exact, analytic: the compiled core's
    partial derivatives of ``ddq``, :meth:`postcapture.dynamics.core.CompiledPlant.derivatives`)."""
    nv = system.nv
    _, Aq, Av, Au, Ap = CompiledPlant(system).derivatives(q, v, system.input_vector(t, u_extra))
    A = np.zeros((2 * nv, 2 * nv))
    A[:nv, nv:] = np.eye(nv)
    if system.n_root_v:
        A[:6, :6] = -ad(v[:6])
    A[nv:, :nv] = Aq
    A[nv:, nv:] = Av
    B = np.zeros((2 * nv, system.n_u))
    B[nv:] = Au
    E = None
    if system.layout.has_target:
        E = np.zeros(2 * nv)
        E[nv:] = Ap @ system.dparams_dmass()
    return Linearization(A, B, E)


@dataclass(frozen=True)
class Mode:
    """One structural mode."""

    frequency_hz: float
    damping_ratio: float
    shape: np.ndarray  # (nv,), mass-normalised
    energy_share: dict  # spring group -> share of the mode's strain energy

    @property
    def dominant(self) -> str:
        """The spring group holding most of the strain energy."""
        return max(self.energy_share, key=self.energy_share.get)


def spring_groups(system: System) -> dict[str, np.ndarray]:
    """Elastic-coordinate indices (into ``e = q[7:]``) grouped by what they are."""
    lay = system.layout
    r = system.n_root_v
    groups: dict[str, list[int]] = {}
    if lay.arm_v:
        groups["arm"] = [i - r for i in lay.arm_v] + [i - r for i in lay.rotor_v if i is not None]
    for p in lay.panels:
        if p.bending_v:
            groups[f"{p.name} bending"] = [i - r for i in p.bending_v]
        if p.torsion_v is not None:
            groups[f"{p.name} torsion"] = [p.torsion_v - r]
    return {k: np.asarray(v, dtype=int) for k, v in groups.items()}


def structural_modes(system: System, q: np.ndarray | None = None) -> list[Mode]:
    """Elastic modes at rest in configuration ``q`` (default: springs at rest).

    Returns the non-rigid modes sorted by frequency (``nv - 6`` for a free stack, ``nv`` on a fixed base).
    """
    q = system.assembly.q_rest.copy() if q is None else np.asarray(q, dtype=float)
    nv = system.nv
    M = CompiledPlant(system).mass_matrix(q)
    r = system.n_root_v
    K = np.zeros((nv, nv))
    D = np.zeros((nv, nv))
    K[r:, r:] = system.K_e
    D[r:, r:] = system.D_e
    # The springs' stiffness is not the only one away from rest (centrifugal terms), but at rest it is.
    w2, phi = sla.eigh(K, M)
    groups = spring_groups(system)
    modes = []
    for j in np.argsort(w2)[r:]:
        omega = np.sqrt(max(w2[j], 0.0))
        shape = phi[:, j]
        e = shape[r:]
        strain = e * (system.K_e @ e)
        total = strain.sum()
        share = {g: float(strain[idx].sum() / total) for g, idx in groups.items()} if total > 0 else {}
        zeta = float(shape @ D @ shape / (2 * omega)) if omega > 0 else 0.0
        modes.append(Mode(omega / (2 * np.pi), zeta, shape, share))
    return modes


def state_space_modes(A: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Natural frequencies (Hz), damping ratios and eigenvectors of a state matrix.

    One entry per oscillatory pair (positive imaginary part) and per real pole, sorted by frequency.
    """
    lam, vec = np.linalg.eig(A)
    keep = lam.imag >= -1e-12 * np.maximum(1.0, np.abs(lam))
    lam, vec = lam[keep], vec[:, keep]
    wn = np.abs(lam)
    with np.errstate(invalid="ignore", divide="ignore"):
        zeta = np.where(wn > 0, -lam.real / np.where(wn > 0, wn, 1.0), 0.0)
    order = np.argsort(wn)
    return wn[order] / (2 * np.pi), zeta[order], vec[:, order]
