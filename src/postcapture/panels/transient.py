"""Tip response of the FEM panel to a tip load history, by modal superposition.

This is the FEM half of the reference's sine-sweep validation (100 s, 800 samples): a force history
along z is spread over the tip edge as a uniform line load, each retained mode responds as a damped
oscillator, and the tip deflection is the sum of the modal responses. Each oscillator is stepped
exactly for a load that is linear between samples (first-order hold), so the only errors are the
modal truncation and the sampling of the load itself.
"""

from __future__ import annotations

import numpy as np
from scipy.linalg import expm

from postcapture.core.errors import DimensionError, PanelModelError, Problem
from postcapture.panels.modes import PanelModes

__all__ = ["tip_edge_weights", "tip_response_modal"]


def tip_edge_weights(modes: PanelModes) -> tuple[np.ndarray, np.ndarray]:
    """Return the tip-edge nodes and the share of a total tip force each one takes (a uniform line load).

    Returns
    -------
    nodes : ndarray of int, shape (n_width + 1,)
        Node indices along the tip edge.
    weights : ndarray, shape (n_width + 1,)
        Consistent nodal shares of a unit total force: ``1/n_width`` inside, half at the corners (sum 1).
    """
    nodes = modes.mesh.tip_nodes
    weights = np.full(nodes.size, 1.0 / modes.mesh.n_width)
    weights[[0, -1]] *= 0.5
    return nodes, weights


def _foh_matrices(omega: float, zeta: float, dt: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Return the exact step of ``q'' + 2 zeta omega q' + omega^2 q = p(t)``, ``p`` linear over a step."""
    aug = np.zeros((4, 4))
    aug[0, 1] = 1.0
    aug[1, 0] = -omega * omega
    aug[1, 1] = -2.0 * zeta * omega
    aug[1, 2] = 1.0  # p enters the acceleration
    aug[2, 3] = 1.0  # p' = s, the constant slope (p_{k+1} - p_k) / dt over the step
    e = expm(aug * dt)
    # x_{k+1} = E_xx x_k + E_xp p_k + E_xs s = E_xx x_k + (E_xp - E_xs/dt) p_k + (E_xs/dt) p_{k+1}
    return e[:2, :2], e[:2, 2] - e[:2, 3] / dt, e[:2, 3] / dt


def tip_response_modal(modes: PanelModes, tip_force, times, *, damping_ratio=0.01, n_modes: int | None = None
                       ) -> np.ndarray:
    """Compute the out-of-plane tip deflection under a tip force history by modal superposition.

    Parameters
    ----------
    modes : PanelModes
        Modes of the cantilevered panel (mass-normalised).
    tip_force : array_like, shape (n_times,)
        Total force along +z on the tip edge at each instant (N), spread as a uniform line load.
    times : array_like, shape (n_times,)
        Uniform, increasing time grid (s); the panel starts at rest at ``times[0]``.
    damping_ratio : float or array_like, shape (n_modes,), optional
        Modal damping ratio (-). Default 0.01.
    n_modes : int, optional
        Number of modes kept, lowest first. Default all of ``modes``.

    Returns
    -------
    ndarray, shape (n_times,)
        Tip deflection along z (m): the line-load-weighted mean of ``w`` over the tip edge, the
        displacement that does work with the applied force.

    Raises
    ------
    DimensionError
        If ``tip_force`` and ``times`` are not 1-D of the same length (at least 2).
    PanelModelError
        If the grid is not uniform and increasing, a damping ratio is negative or not finite, or
        ``n_modes`` is out of range.

    Notes
    -----
    With mass-normalised shapes ``phi_j`` the modal coordinates obey
    ``q_j'' + 2 zeta_j omega_j q_j' + omega_j^2 q_j = g_j F(t)`` with ``g_j = sum_n c_n w_j(n)`` over the
    tip nodes (shares ``c_n``), and the tip deflection is ``sum_j g_j q_j``. Each step uses the matrix
    exponential of the oscillator augmented with the load and its slope (first-order hold).
    """
    t = np.asarray(times, dtype=float)
    f = np.asarray(tip_force, dtype=float)
    if t.ndim != 1 or f.shape != t.shape or t.size < 2:
        raise DimensionError(f"`tip_force` and `times` must be 1-D of the same length >= 2; "
                             f"found shapes {f.shape} and {t.shape}")
    dt = (t[-1] - t[0]) / (t.size - 1)
    problems = []
    if not np.all(np.isfinite(t)) or not dt > 0 or np.max(np.abs(np.diff(t) - dt)) > 1e-6 * dt:
        problems.append(Problem("times", "a uniform, increasing grid", f"steps from {np.min(np.diff(t)):.6g} "
                                                                     f"to {np.max(np.diff(t)):.6g} s"))
    n = modes.n_modes if n_modes is None else n_modes
    if isinstance(n, bool) or not isinstance(n, (int, np.integer)) or not 1 <= n <= modes.n_modes:
        problems.append(Problem("n_modes", f"an integer in [1, {modes.n_modes}]", repr(n_modes)))
        n = modes.n_modes
    zeta = np.asarray(damping_ratio, dtype=float)
    if zeta.ndim == 0:
        zeta = np.full(n, float(zeta))
    elif zeta.shape == (modes.n_modes,):
        zeta = zeta[:n]
    if zeta.shape != (n,) or not np.all(np.isfinite(zeta)) or np.any(zeta < 0):
        problems.append(Problem("damping_ratio",
                                f"finite values >= 0: a scalar, {n} or {modes.n_modes} of them",
                                repr(damping_ratio)))
    if not np.all(np.isfinite(f)):
        problems.append(Problem("tip_force", "finite values (N)", "non-finite entries"))
    if problems:
        raise PanelModelError(problems)

    nodes, weights = tip_edge_weights(modes)
    gain = weights @ modes.shapes[nodes, 2, :n]  # (n,) modal force per unit tip force, and output map
    omega = 2.0 * np.pi * modes.frequencies_hz[:n]
    phis, g0s, g1s = zip(*(_foh_matrices(w, z, dt) for w, z in zip(omega, zeta)))
    phi, g0, g1 = np.array(phis), np.array(g0s), np.array(g1s)  # (n, 2, 2), (n, 2), (n, 2)
    b0 = g0 * gain[:, None]
    b1 = g1 * gain[:, None]
    x = np.zeros((n, 2))
    q = np.zeros((t.size, n))
    for k in range(t.size - 1):
        x = np.einsum("mij,mj->mi", phi, x) + b0 * f[k] + b1 * f[k + 1]
        q[k + 1] = x[:, 0]
    return q @ gain
