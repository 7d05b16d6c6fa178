"""The stability limit of an explicit integrator on a plant, and the refusal of a step beyond it.

An explicit Runge-Kutta method is stable for a linear mode ``dx/dt = lambda x`` only while ``h lambda``
stays in its stability region ``|R(z)| <= 1``, ``R(z) = 1 + z b^T (I - z A)^-1 1`` (a polynomial for an
explicit tableau). The panels' stiffness-proportional dampers put real eigenvalues at about
``-beta omega^2``, so RK4's limit falls quickly with the panel segments (2.2 ms at N = 5, 0.18 ms at
N = 20, 3.6 us at N = 50); beyond it a run returns a finite but meaningless trajectory. So an explicit
step is checked against the eigenvalues of the plant's linearisation at its starting state (exact,
from the compiled core's partials) and refused when too large, with the largest stable step in the
message. Implicit (A-stable) tableaux are not checked.
"""

from __future__ import annotations

import numpy as np

from postcapture.core.errors import DomainError
from postcapture.dynamics.liegroup import ad

__all__ = ["StepTooLargeError", "stability_limit", "check_step", "is_explicit"]


class StepTooLargeError(DomainError):
    """An explicit integrator's step beyond the plant's stability limit (``limit`` in s)."""

    def __init__(self, message: str, step: float = float("nan"), limit: float = float("nan")):
        self.step = step
        self.limit = limit
        super().__init__(message)


def is_explicit(tableau) -> bool:
    """True when every stage is explicit (``A`` strictly lower triangular)."""
    return bool(np.all(np.diag(np.asarray(tableau.A)) == 0.0))


def _polynomial(tableau) -> np.ndarray:
    """Coefficients ``c_k`` of ``R(z) = sum c_k z^k`` of an explicit tableau."""
    A, b = np.asarray(tableau.A, dtype=float), np.asarray(tableau.b, dtype=float)
    s = len(b)
    coef, x = [1.0], np.ones(s)
    for _ in range(s):
        coef.append(float(b @ x))
        x = A @ x
    return np.array(coef)


def _ray_limits(coef: np.ndarray, lam: np.ndarray) -> np.ndarray:
    """For each eigenvalue, the largest ``h |lambda|`` along its ray before ``|R| > 1`` (grid, then bisection)."""
    direction = lam / np.abs(lam)
    grid = np.linspace(0.0, 8.0, 4001)[1:]
    R = np.abs(np.polyval(coef[::-1], grid[None, :] * direction[:, None]))
    out_ = R > 1.0 + 1e-9
    first = np.where(out_.any(axis=1), out_.argmax(axis=1), grid.size - 1)
    lo, hi = np.where(first > 0, grid[np.maximum(first - 1, 0)], 0.0), grid[first]
    for _ in range(40):
        mid = 0.5 * (lo + hi)
        bad = np.abs(np.polyval(coef[::-1], mid * direction)) > 1.0 + 1e-9
        hi, lo = np.where(bad, mid, hi), np.where(bad, lo, mid)
    return lo


def linear_state_matrix(plant, q, v) -> np.ndarray:
    """``A`` of the tangent linearisation at ``(q, v)`` with the inputs held at zero."""
    nv = plant.nv
    _, Aq, Av, _, _ = plant.derivatives(q, v, np.zeros(plant.nu))
    A = np.zeros((2 * nv, 2 * nv))
    A[:nv, nv:] = np.eye(nv)
    if plant.nq == plant.nv + 1:
        A[:6, :6] = -ad(np.asarray(v, dtype=float)[:6])
    A[nv:, :nv] = Aq
    A[nv:, nv:] = Av
    return A


def stability_limit(plant, q, v, tableau=None) -> tuple[float, complex]:
    """The largest stable step of ``tableau`` (default the plant's) at ``(q, v)``, and the eigenvalue that sets it.

    ``inf`` for an implicit tableau or a plant without a limiting mode.
    """
    tableau = plant.tableau if tableau is None else tableau
    if not is_explicit(tableau):
        return float("inf"), complex("nan")
    lam = np.linalg.eigvals(linear_state_matrix(plant, q, v))
    scale = max(1.0, float(np.abs(lam).max()))
    lam = np.minimum(lam.real, 0.0) + 1j * lam.imag  # growing physical modes (a tumble) are not the method's
    lam = lam[np.abs(lam) > 1e-9 * scale]
    if not lam.size:
        return float("inf"), complex("nan")
    limits = _ray_limits(_polynomial(tableau), lam) / np.abs(lam)
    k = int(np.argmin(limits))
    return float(limits[k]), complex(lam[k])


def check_step(plant, q, v, h: float, tableau=None) -> None:
    """Refuse an explicit step ``h`` beyond the stability limit at ``(q, v)``.

    Raises
    ------
    StepTooLargeError
        Naming the step, the limit, the eigenvalue that sets it and what to do instead.
    """
    tableau = plant.tableau if tableau is None else tableau
    if not is_explicit(tableau):
        return
    limit, lam = stability_limit(plant, q, v, tableau)
    if h > limit:
        name = getattr(tableau, "name", "the explicit method")
        raise StepTooLargeError(
            f"step: {h:.6g} s is beyond {name}'s stability limit for this model, {limit:.6g} s (set by the "
            f"eigenvalue {lam.real:.4g}{lam.imag:+.4g}i 1/s of the linearised plant at its starting state): "
            f"use a step <= {limit:.4g} s or an L-stable method (sdirk4, sdirk3)", step=h, limit=limit)
