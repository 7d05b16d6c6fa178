"""Model-based attitude EKF, as in the reference: the process model propagates, the star tracker corrects.

The filter's state is a full copy of the plant state ``x`` (carried by the process model with the
current target-mass estimate), but its error state is the attitude only: ``dtheta`` (3, body frame,
right perturbation). Its transition is the attitude block of the model's exact step Jacobian; a star
tracker quaternion corrects it through the innovation ``box_minus(q_meas, q_est)`` with ``H = I``.
The reference tuning is ``R = 0.01^2 I3``, ``Q = 0.0007^2 I3`` per step, ``P0 = 0.02^2 I3``. The
covariance arithmetic, the update and the recovery run in the compiled engine (``pc_attitude_ekf.c``); the
plant copy (any process model) steps and takes the correction here.
"""

from __future__ import annotations

import ctypes
from dataclasses import dataclass, field

import numpy as np

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
        self.att = model.tangent_attitude
        self.last_gain = np.zeros((3, 3))
        self.extra_process_noise = None
        self.last_prediction: Prediction | None = None
        self._attach(self._eng.atekf_create(np.ascontiguousarray(tuning.P0, dtype=float),
                                            np.ascontiguousarray(tuning.Q, dtype=float), REACQUIRE_ATTITUDE,
                                            ctypes.byref(self._policy(3))))
        self._P = self._state.reshape(3, 3)

    @property
    def q_BN(self) -> np.ndarray:
        """Current attitude estimate (scalar first)."""
        return self.model.attitude(self.x)

    def predict(self, t: float, dt: float, u=None) -> None:
        """Propagate the plant copy and the attitude covariance from ``t`` to ``t + dt`` (``u`` unused)."""
        p = self.model.predict(self.x, t, dt, jacobians=True)
        Fa = np.ascontiguousarray(p.F[self.att, self.att])
        extra = None if self.extra_process_noise is None else np.ascontiguousarray(self.extra_process_noise,
                                                                                      dtype=float)
        self._eng.atekf_predict(self._handle, float(t + dt), Fa, extra)
        self.x = p.x
        self.last_prediction = p
        self._sync()

    def update(self, z):
        """Correct with a star-tracker :class:`~postcapture.estimation.filter.Measurement`; returns the result or None.

        A non-finite sample is skipped; an innovation outside the chi-square gate is rejected.
        """
        dtheta, K = np.zeros(3), np.zeros((3, 3))
        self._eng.atekf_update(self._handle, float(z.t), np.ascontiguousarray(z.value, dtype=float),
                               np.ascontiguousarray(self.q_BN), np.ascontiguousarray(z.R, dtype=float), dtheta, K,
                               ctypes.byref(self._res))
        res = self._result(z.kind, z.t, K)
        self.last_gain = K
        if res is not None and res.accepted:
            dx = np.zeros(self.model.n)
            dx[self.att] = dtheta
            self.x = self.model.retract(self.x, dx)
        return res
