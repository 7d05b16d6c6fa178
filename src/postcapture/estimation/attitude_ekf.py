"""Model-based attitude EKF, as in the reference: the process model propagates, the star tracker corrects.

The filter's state is a full copy of the plant state ``x`` (carried by the process model with the
current target-mass estimate), but its error state is the attitude only: ``dtheta`` (3, body frame,
right perturbation). Its transition is the attitude block of the model's exact step Jacobian; a star
tracker quaternion corrects it through the innovation ``box_minus(q_meas, q_est)`` with ``H = I``.
The reference tuning is ``R = 0.01^2 I3``, ``Q = 0.0007^2 I3`` per step, ``P0 = 0.02^2 I3``.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass

import numpy as np

from postcapture.core import kalman
from postcapture.core import rotations as rot
from postcapture.core.errors import CovarianceError, FilterDivergenceError
from postcapture.core.prediction import Prediction

__all__ = ["AttitudeEKFTuning", "AttitudeEKF"]

logger = logging.getLogger(__name__)


@dataclass(frozen=True)
class AttitudeEKFTuning:
    """Noise model of the attitude EKF (rad^2).

    Parameters
    ----------
    R : array_like, shape (3, 3)
        Star-tracker covariance assumed by the filter.
    Q : array_like, shape (3, 3)
        Process noise added to the attitude error per filter step.
    P0 : array_like, shape (3, 3)
        Initial attitude covariance.
    gate_probability : float or None
        Chi-square gate on the star-tracker NIS; None disables gating.
    max_consecutive_rejections : int
        So many gated-out samples in a row mean the filter lost the attitude: divergence.
    """

    R: np.ndarray
    Q: np.ndarray
    P0: np.ndarray
    gate_probability: float | None = 0.9999
    max_consecutive_rejections: int = 20

    @classmethod
    def reference(cls) -> "AttitudeEKFTuning":
        """The reference's tuning: R = 0.01^2 I3, Q = 0.0007^2 I3, P0 = 0.02^2 I3."""
        return cls(R=0.01**2 * np.eye(3), Q=0.0007**2 * np.eye(3), P0=0.02**2 * np.eye(3))


class AttitudeEKF:
    """Attitude EKF around a :class:`~postcapture.estimation.process.ProcessModel`.

    Parameters
    ----------
    model : ProcessModel
        The filter's own plant copy (its ``mass`` is set by the caller, e.g. a dual scheme).
    tuning : AttitudeEKFTuning
    x0 : ndarray, shape (nx,)
        Initial plant state (its attitude is the initial attitude estimate).
    name : str
        Filter name for logs and errors.
    raise_on_divergence : bool
        Raise :class:`FilterDivergenceError` on divergence (default) or stop and flag it.
    """

    def __init__(self, model, tuning: AttitudeEKFTuning, x0, name: str = "ekf", raise_on_divergence: bool = True):
        self.model = model
        self.tuning = tuning
        self.name = name
        self.x = np.array(x0, dtype=float)
        self.P = np.array(tuning.P0, dtype=float)
        self.att = model.tangent_attitude
        self.raise_on_divergence = raise_on_divergence
        self.diverged = False
        self.message = ""
        self.cause = ""
        self._rejections = 0
        self.last_gain = np.zeros((3, 3))

    @property
    def q_BN(self) -> np.ndarray:
        """Current attitude estimate (scalar first)."""
        return self.model.attitude(self.x)

    def _fail(self, t: float, cause: str) -> None:
        self.diverged = True
        self.cause = cause
        self.message = f"diverged at t = {t:.6g} s: {cause}"
        if self.raise_on_divergence:
            raise FilterDivergenceError(self.name, t, cause)
        logger.warning("%s %s", self.name, self.message)

    def predict(self, t: float, dt: float, Q_extra=None) -> Prediction:
        """Propagate the plant copy and the attitude covariance from ``t`` to ``t + dt``.

        ``Q_extra`` (3, 3) is added to the tuning's ``Q`` for this step (e.g. what the plant copy's
        mass uncertainty does to its attitude, see :mod:`postcapture.estimation.dual`).
        """
        p = self.model.predict(self.x, t, dt, jacobians=True)
        Fa = p.F[self.att, self.att]
        Q = self.tuning.Q if Q_extra is None else self.tuning.Q + Q_extra
        self.P = kalman.symmetrize(Fa @ self.P @ Fa.T + Q)
        self.x = p.x
        if not (np.all(np.isfinite(self.x)) and np.all(np.isfinite(self.P))):
            self._fail(t + dt, "non-finite state or covariance after the prediction")
        return p

    def update(self, q_meas, t: float, R=None):
        """Correct with a star-tracker quaternion; returns the update result, or None when skipped.

        A non-finite sample is skipped; an innovation outside the chi-square gate is rejected.
        """
        q_meas = np.asarray(q_meas, dtype=float)
        self.last_gain = np.zeros((3, 3))
        if not np.all(np.isfinite(q_meas)):
            return None
        innovation = rot.box_minus(q_meas, self.q_BN)
        try:
            res = kalman.update(np.zeros(3), self.P, innovation, np.eye(3), self.tuning.R if R is None else R,
                                gate_probability=self.tuning.gate_probability)
        except CovarianceError as exc:
            self._fail(t, str(exc))
            return None
        if not res.accepted:
            self._rejections += 1
            logger.info("%s: star-tracker sample at t = %.6g s rejected (NIS %.3g)", self.name, t, res.nis)
            if self._rejections >= self.tuning.max_consecutive_rejections:
                self._fail(t, f"{self._rejections} star-tracker samples in a row rejected by the gate")
            return res
        self._rejections = 0
        dx = np.zeros(self.model.n)
        dx[self.att] = res.x
        self.x = self.model.retract(self.x, dx)
        self.P = res.P
        self.last_gain = res.K
        return res
