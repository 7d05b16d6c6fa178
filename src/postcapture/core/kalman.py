"""Kalman filter kernels: linear predict and a Joseph-form update with chi-square gating.

The kernels are pure functions on float64 arrays; they never mutate their inputs. The update takes
the *innovation* ``nu = z - h(x)`` rather than the measurement ``z``, so that a caller can form it on
a manifold (``box_minus`` for quaternions) and hand the kernel a plain vector.

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
from scipy.linalg.lapack import dpotrf, dpotrs
from scipy.stats import chi2

from postcapture.core.errors import CovarianceError, DimensionError

__all__ = ["UpdateResult", "predict", "update", "gate_threshold", "symmetrize", "KalmanFilter"]


def symmetrize(P: np.ndarray) -> np.ndarray:
    """Return ``(P + P^T) / 2``."""
    return 0.5 * (P + P.T)


def _check(M, name: str, shape: tuple[int, ...]) -> np.ndarray:
    M = np.asarray(M, dtype=float)
    if M.shape != shape:
        raise DimensionError(
            f"Incompatible dimensions of {name} matrix; expected {shape} but found {M.shape}"
        )
    return M


def _state(x) -> np.ndarray:
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


def predict(x, P, F, Q) -> tuple[np.ndarray, np.ndarray]:
    """Linear prediction ``x <- F x``, ``P <- F P F^T + Q`` (symmetrised).

    Parameters
    ----------
    x : array_like, shape (n,)
        State estimate.
    P : array_like, shape (n, n)
        State covariance.
    F : array_like, shape (n, n)
        State transition matrix over the step.
    Q : array_like, shape (n, n)
        Discrete process-noise covariance over the step.

    Returns
    -------
    x : ndarray, shape (n,)
    P : ndarray, shape (n, n)

    Raises
    ------
    DimensionError
        If a shape is wrong; the message names the matrix, the expected and the found shape.
    """
    x = _state(x)
    n = x.size
    P = _check(P, "P", (n, n))
    F = _check(F, "F", (n, n))
    Q = _check(Q, "Q", (n, n))
    return F @ x, symmetrize(F @ P @ F.T + Q)


@dataclass(frozen=True, slots=True)
class UpdateResult:
    """Outcome of one measurement update.

    Attributes
    ----------
    x : ndarray, shape (n,)
        Updated state (the prior one when the innovation was gated out).
    P : ndarray, shape (n, n)
        Updated covariance, Joseph form, symmetrised (the prior one when gated out).
    innovation : ndarray, shape (m,)
        The innovation ``z - h(x)`` that was processed.
    S : ndarray, shape (m, m)
        Innovation covariance.
    K : ndarray, shape (n, m)
        Kalman gain (computed even when the innovation was gated out, but then not applied).
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


def update(x, P, innovation, H, R, *, gate_probability: float | None = None, consider=None) -> UpdateResult:
    r"""Kalman measurement update in Joseph form, with optional chi-square innovation gating.

    Parameters
    ----------
    x : array_like, shape (n,)
        Prior state.
    P : array_like, shape (n, n)
        Prior covariance.
    innovation : array_like, shape (m,)
        ``z - h(x)``, formed by the caller (with ``box_minus`` for attitudes).
    H : array_like, shape (m, n)
        Measurement Jacobian.
    R : array_like, shape (m, m)
        Measurement-noise covariance.
    gate_probability : float, optional
        When given, the innovation is rejected (state and covariance returned unchanged) if its NIS
        exceeds ``chi2.ppf(gate_probability, m)``.
    consider : slice or array of int, optional
        Consider states (Schmidt-Kalman): their gain rows are set to zero, so their estimate never moves
        while their covariance (and their cross-covariance with the other states) still enters ``S``,
        the gain of the others, and ``P``. The Joseph form is exact for this suboptimal gain.

    Returns
    -------
    UpdateResult

    Raises
    ------
    DimensionError
        If a shape is wrong; the message names the matrix, the expected and the found shape.
    CovarianceError
        If the innovation covariance ``S`` is not finite or not positive definite.

    Notes
    -----
    .. math::

        S = H P H^T + R, \quad K = P H^T S^{-1}, \quad x^+ = x + K \nu,

        P^+ = (I - K H) P (I - K H)^T + K R K^T.

    ``S^-1`` is never formed: ``K`` and the NIS come from a Cholesky factorisation of ``S``. The Joseph
    form keeps ``P^+`` symmetric positive definite for any gain, which the short form ``(I - K H) P``
    does not under rounding. Its products are taken as ``A = P - K (H P)``, ``A - (A H^T) K^T``: the same
    congruence, at ``O(n^2 m)`` instead of ``O(n^3)``.
    """
    x = _state(x)
    n = x.size
    nu = np.asarray(innovation, dtype=float)
    if nu.ndim != 1:
        raise DimensionError(
            f"Incompatible dimensions of innovation vector; expected (m,) but found {nu.shape}"
        )
    m = nu.size
    P = _check(P, "P", (n, n))
    H = _check(H, "H", (m, n))
    R = _check(R, "R", (m, m))
    PHt = P @ H.T
    S = symmetrize(H @ PHt + R)
    if not np.isfinite(S).all():
        raise CovarianceError("innovation covariance S is not finite")
    # LAPACK directly: scipy's cho_factor/cho_solve wrappers cost five times the factorisation of a small S
    L, info = dpotrf(S, lower=1, clean=0)
    if info != 0:
        raise CovarianceError("innovation covariance S = H P H^T + R is not positive definite")
    # one triangular solve pair for both S^-1 nu and S^-1 H P
    sol, _ = dpotrs(L, np.column_stack([nu, PHt.T]), lower=1)
    nis = float(nu @ sol[:, 0])
    K = sol[:, 1:].T
    if consider is not None:
        K[consider] = 0.0
    threshold = None if gate_probability is None else gate_threshold(gate_probability, m)
    if threshold is not None and not nis <= threshold:
        return UpdateResult(x.copy(), P.copy(), nu, S, K, nis, False, threshold)
    # (I - K H) P (I - K H)^T, associated so that every product is n x n x m rather than n^3
    A = P - K @ (H @ P)
    P_new = symmetrize(A - (A @ H.T) @ K.T + K @ R @ K.T)
    return UpdateResult(x + K @ nu, P_new, nu, S, K, nis, True, threshold)


class KalmanFilter:
    """Thin stateful wrapper over :func:`predict` and :func:`update` for linear filters.

    Parameters
    ----------
    x0 : array_like, shape (n,)
        Initial state.
    P0 : array_like, shape (n, n)
        Initial covariance.

    Examples
    --------
    >>> import numpy as np
    >>> kf = KalmanFilter(np.zeros(1), np.eye(1))
    >>> kf.predict(np.eye(1), 0.5 * np.eye(1))
    >>> r = kf.update(np.array([1.0]) - kf.x, np.eye(1), np.eye(1))
    >>> round(float(kf.x[0]), 12), round(float(kf.P[0, 0]), 12)
    (0.6, 0.6)
    """

    def __init__(self, x0, P0):
        self.x = _state(x0).copy()
        self.P = symmetrize(_check(P0, "P0", (self.x.size, self.x.size)))

    def predict(self, F, Q) -> None:
        """Propagate the state and covariance; see :func:`predict`."""
        self.x, self.P = predict(self.x, self.P, F, Q)

    def update(self, innovation, H, R, *, gate_probability: float | None = None) -> UpdateResult:
        """Process one innovation ``z - H x``; see :func:`update`."""
        result = update(self.x, self.P, innovation, H, R, gate_probability=gate_probability)
        self.x, self.P = result.x, result.P
        return result
