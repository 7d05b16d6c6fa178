"""Model-based attitude EKF, as in the reference: the process model propagates, the star tracker corrects.

The filter's state is a full copy of the plant state ``x`` (carried by the process model with the
current target-mass estimate), but its error state is the attitude only: ``dtheta`` (3, body frame,
right perturbation). Its transition is the attitude block of the model's exact step Jacobian; a star
tracker quaternion corrects it through the innovation ``box_minus(q_meas, q_est)`` with ``H = I``.
The reference tuning is ``R = 0.01^2 I3``, ``Q = 0.0007^2 I3`` per step, ``P0 = 0.02^2 I3``.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from postcapture.core import kalman
from postcapture.core import rotations as rot
from postcapture.core.errors import CovarianceError
from postcapture.core.prediction import Prediction
from postcapture.estimation.filter import FilterBase, RecoveryPolicy

__all__ = ["AttitudeEKFTuning", "AttitudeEKF", "REACQUIRE_ATTITUDE"]

REACQUIRE_ATTITUDE = 1.0
"""Attitude 1-sigma after a divergence (rad): the next star-tracker sample decides."""


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
    recovery : RecoveryPolicy
        When persistent gating or too-large innovations start a recovery (see :mod:`.filter`).
    """

    R: np.ndarray
    Q: np.ndarray
    P0: np.ndarray
    gate_probability: float | None = 0.9999
    recovery: RecoveryPolicy = field(default_factory=RecoveryPolicy)

    @classmethod
    def reference(cls) -> "AttitudeEKFTuning":
        """The reference's tuning: R = 0.01^2 I3, Q = 0.0007^2 I3, P0 = 0.02^2 I3."""
        return cls(R=0.01**2 * np.eye(3), Q=0.0007**2 * np.eye(3), P0=0.02**2 * np.eye(3))


class AttitudeEKF(FilterBase):
    """Attitude EKF around a :class:`~postcapture.estimation.process.ProcessModel` (the stepper of :mod:`.filter`).

    Parameters
    ----------
    model : ProcessModel
        The filter's plant copy (its ``mass`` is set by the caller, e.g. a dual scheme, which owns the copy).
    tuning : AttitudeEKFTuning
    x0 : ndarray, shape (nx,)
        Initial plant state (its attitude is the initial attitude estimate).
    name : str
        Filter name for logs and events.

    Attributes
    ----------
    extra_process_noise : ndarray (3, 3) or None
        Added to the tuning's ``Q`` at the next prediction (e.g. what the plant copy's mass uncertainty
        does to its attitude, see :mod:`postcapture.estimation.dual`).
    last_prediction : Prediction
        The plant step of the last prediction (with its Jacobians).
    """

    labels = ("dtheta_x", "dtheta_y", "dtheta_z")

    def __init__(self, model, tuning: AttitudeEKFTuning, x0, name: str = "ekf"):
        self._init_base(name, tuning.recovery, tuning.gate_probability)
        self.model = model
        self.tuning = tuning
        self.x = np.array(x0, dtype=float)
        self.P = np.array(tuning.P0, dtype=float)
        self.att = model.tangent_attitude
        self.last_gain = np.zeros((3, 3))
        self.extra_process_noise = None
        self.last_prediction: Prediction | None = None

    @property
    def q_BN(self) -> np.ndarray:
        """Current attitude estimate (scalar first)."""
        return self.model.attitude(self.x)

    def predict(self, t: float, dt: float, u=None) -> None:
        """Propagate the plant copy and the attitude covariance from ``t`` to ``t + dt`` (``u`` unused)."""
        p = self.model.predict(self.x, t, dt, jacobians=True)
        Fa = p.F[self.att, self.att]
        Q = self.tuning.Q if self.extra_process_noise is None else self.tuning.Q + self.extra_process_noise
        self.P = kalman.symmetrize(Fa @ self.P @ Fa.T + Q)
        self.x = p.x
        self.last_prediction = p
        self.check_covariance(t + dt, "prediction")

    def update(self, z):
        """Correct with a star-tracker :class:`~postcapture.estimation.filter.Measurement`; returns the result or None.

        A non-finite sample is skipped; an innovation outside the chi-square gate is rejected.
        """
        q_meas = np.asarray(z.value, dtype=float)
        self.last_gain = np.zeros((3, 3))
        if not np.all(np.isfinite(q_meas)):
            self.counts["measurements_missing"] += 1
            return None
        innovation = rot.box_minus(q_meas, self.q_BN)
        try:
            res = kalman.update(np.zeros(3), self.P, innovation, np.eye(3), z.R, gate_probability=self.gate(z.kind))
        except CovarianceError as exc:
            self.diverge(z.t, str(exc))
            return None
        if res.accepted:
            dx = np.zeros(self.model.n)
            dx[self.att] = res.x
            self.x = self.model.retract(self.x, dx)
            self.P = res.P
            self.last_gain = res.K
        self.record(z.kind, z.t, res.nis, 3, res.accepted)
        return res

    def _recover(self, kind: str, t: float) -> None:
        self.P = self.P * self.policy.inflation

    def _reinitialise(self, t: float) -> None:
        # the attitude is lost: the next star-tracker sample (let through without a gate) sets it
        self.P = np.array(self.tuning.P0, dtype=float) + REACQUIRE_ATTITUDE**2 * np.eye(3)
