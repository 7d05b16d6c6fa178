"""The engine's Kalman kernels as pure functions: linear predict and a Joseph-form update with gating.

The arithmetic is the compiled engine's (``dynamics/csrc/pc_kalman.c``), the one every filter runs; these
functions check shapes, never mutate their inputs and return new arrays. Symbols as in
:mod:`postcapture.core.kalman`.
"""

from __future__ import annotations

import ctypes

import numpy as np

from postcapture.core.errors import CovarianceError, DimensionError
from postcapture.core.kalman import UpdateResult, check_shape, check_state, gate_threshold, symmetrize
from postcapture.dynamics import engine as _engine

__all__ = ["predict", "update", "KalmanFilter"]


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
    x = check_state(x)
    n = x.size
    P = np.array(check_shape(P, "P", (n, n)), order="C")
    F = np.ascontiguousarray(check_shape(F, "F", (n, n)))
    Q = np.ascontiguousarray(check_shape(Q, "Q", (n, n)))
    _engine.engine().kf_predict(n, P, F, Q, np.zeros(2 * n * n + 1))
    return F @ x, P


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
    x = check_state(x)
    n = x.size
    nu = np.asarray(innovation, dtype=float)
    if nu.ndim != 1:
        raise DimensionError(f"Incompatible dimensions of innovation vector; expected (m,) but found {nu.shape}")
    m = nu.size
    if not 1 <= m <= _engine.MAX_MEAS:
        raise DimensionError(f"innovation: expected 1 to {_engine.MAX_MEAS} components, found {m}")
    P_new = np.array(check_shape(P, "P", (n, n)), order="C")
    H = np.ascontiguousarray(check_shape(H, "H", (m, n)))
    R = np.ascontiguousarray(check_shape(R, "R", (m, m)))
    flags = None
    if consider is not None:
        flags = np.zeros(n, dtype=np.uint8)
        flags[consider] = 1
    threshold = -1.0 if gate_probability is None else gate_threshold(gate_probability, m)
    eng = _engine.engine()
    dx, K, res = np.zeros(n), np.zeros((n, m)), _engine.UpdateStruct()
    status = eng.kf_update(n, m, P_new, np.ascontiguousarray(nu), H, R, flags, threshold, dx, K, ctypes.byref(res),
                           np.zeros(eng.kf_workspace(n, m)))
    if status == 2:
        raise CovarianceError("innovation covariance S is not finite")
    if status == 3:
        raise CovarianceError("innovation covariance S = H P H^T + R is not positive definite")
    S = np.ctypeslib.as_array(res.S)[: m * m].reshape(m, m).copy()
    thr = None if gate_probability is None else threshold
    return UpdateResult(x + dx, P_new, nu, S, K, float(res.nis),
                        bool(res.accepted), thr)


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
        self.x = check_state(x0).copy()
        self.P = symmetrize(check_shape(P0, "P0", (self.x.size, self.x.size)))

    def predict(self, F, Q) -> None:
        """Propagate the state and covariance; see :func:`predict`."""
        self.x, self.P = predict(self.x, self.P, F, Q)

    def update(self, innovation, H, R, *, gate_probability: float | None = None) -> UpdateResult:
        """Process one innovation ``z - H x``; see :func:`update`."""
        result = update(self.x, self.P, innovation, H, R, gate_probability=gate_probability)
        self.x, self.P = result.x, result.P
        return result
