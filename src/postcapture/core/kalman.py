"""What the Kalman kernels share: their symbols, the chi-square gate and an update's outcome.

The kernels themselves (linear predict, the Joseph-form update with gating and consider states) run in
the compiled engine with the filters (``dynamics/csrc/pc_kalman.c``); :mod:`postcapture.estimation.kernels`
calls them as pure functions. An update takes the *innovation* ``nu = z - h(x)`` rather than the
measurement ``z``, so that a caller can form it on a manifold (``box_minus`` for quaternions).

Symbols (textbook names, shapes with ``n`` states and ``m`` measurements):

=====  ============  =====================================================
``x``  (n,)          state (or error-state) estimate
``P``  (n, n)        state covariance
``F``  (n, n)        state transition matrix
``Q``  (n, n)        discrete process-noise covariance
``H``  (m, n)        measurement Jacobian
``R``  (m, m)        measurement-noise covariance
``S``  (m, m)        innovation covariance ``H P H^T + R``
``K``  (n, m)        Kalman gain ``P H^T S^-1``
=====  ============  =====================================================
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache

import numpy as np
from scipy.stats import chi2

from postcapture.core.errors import DimensionError

__all__ = ["UpdateResult", "gate_threshold", "symmetrize", "check_shape", "check_state"]


def symmetrize(P: np.ndarray) -> np.ndarray:
    """Return ``(P + P^T) / 2``."""
    return 0.5 * (P + P.T)


def check_shape(M, name: str, shape: tuple[int, ...]) -> np.ndarray:
    """``M`` as a float array of ``shape``, or a DimensionError naming it, the expected and the found shape."""
    M = np.asarray(M, dtype=float)
    if M.shape != shape:
        raise DimensionError(
            f"Incompatible dimensions of {name} matrix; expected {shape} but found {M.shape}"
        )
    return M


def check_state(x) -> np.ndarray:
    """``x`` as a 1-D float array, or a DimensionError."""
    x = np.asarray(x, dtype=float)
    if x.ndim != 1:
        raise DimensionError(f"Incompatible dimensions of x vector; expected (n,) but found {x.shape}")
    return x


def gate_threshold(probability: float, dim: int) -> float:
    """Chi-square gate: ``chi2.ppf(probability, dim)``; an innovation with a larger NIS is rejected.

    Parameters
    ----------
    probability : float
        Probability mass of the gate, in (0, 1) (for example 0.9999).
    dim : int
        Dimension of the innovation.
    """
    if not 0.0 < probability < 1.0:
        raise ValueError(f"`gate_probability` must lie in (0, 1); found {probability}")
    return _chi2_quantile(float(probability), int(dim))


@lru_cache(maxsize=512)
def _chi2_quantile(probability: float, dim: int) -> float:
    # scipy's ppf costs about 0.5 ms a call, as much as a whole update of a 90-state filter
    return float(chi2.ppf(probability, dim))


@dataclass(frozen=True, slots=True)
class UpdateResult:
    """Outcome of one measurement update.

    Attributes
    ----------
    x : ndarray, shape (n,) or None
        Updated state (the prior one when the innovation was gated out); None from a filter, whose
        state is its own.
    P : ndarray, shape (n, n) or None
        Updated covariance, Joseph form, symmetrised (the prior one when gated out); None from a filter.
    innovation : ndarray, shape (m,)
        The innovation ``z - h(x)`` that was processed.
    S : ndarray, shape (m, m)
        Innovation covariance.
    K : ndarray, shape (n, m) or None
        Kalman gain (computed even when the innovation was gated out, but then not applied); None from a
        filter that does not report it.
    nis : float
        Normalised innovation squared ``nu^T S^-1 nu``.
    accepted : bool
        False when the chi-square gate rejected the innovation.
    threshold : float or None
        The gate threshold on the NIS, or None when gating was off.
    """

    x: np.ndarray
    P: np.ndarray
    innovation: np.ndarray
    S: np.ndarray
    K: np.ndarray
    nis: float
    accepted: bool
    threshold: float | None
