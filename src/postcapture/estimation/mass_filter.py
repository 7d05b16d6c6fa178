"""The sigmoid-constrained EKF on the target mass (the reference's parameter filter).

The filter estimates ``x`` with ``theta = b + (a - b) / (1 + exp(-c x))`` (reference eq. 4), so the mass
stays in ``(b, a)``. Its process noise on ``x`` is scheduled linearly from ``q_start`` to ``q_end`` over
the run (the reference: 20.1 to 0.1, large first for fast convergence, small at the end to stop
oscillation). Its measurement is ``z = [chaser acceleration (3), arm joint accelerations (n_arm)]``,
predicted by the plant model at the attitude filter's state, with covariance ``R`` (the reference:
``diag(1e-4 I3, 1e-2 I7)``).

With ``accel_bias=True`` the filter also carries the accelerometer's bias (3, a random walk): a
constant bias the size of the noise is otherwise read as a mass error before the manoeuvre starts.

The measurement Jacobian ``dz/dtheta`` is analytic. ``sensitivity="partial"`` is the reference's: the
derivative at a fixed plant state. ``sensitivity="total"`` adds the plant state's own dependence on
the mass: ``dz/dtheta = H S + h`` with ``S = dx/dtheta`` carried through the model's exact step Jacobians
(``S <- F S + g``), the recurrent derivative of Wan and Nelson's dual EKF. The caller (the dual scheme)
owns ``S``.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from postcapture.core import kalman
from postcapture.core.errors import CovarianceError
from postcapture.core.sigmoid import SigmoidMap
from postcapture.estimation.filter import FilterBase, RecoveryPolicy

__all__ = ["MassFilterTuning", "MassFilter"]


@dataclass(frozen=True)
class MassFilterTuning:
    """Tuning of the mass filter.

    Parameters
    ----------
    R_diag : array_like, shape (m,)
        Measurement variances: accelerometer (m/s^2)^2 then joint accelerations (rad/s^2)^2.
    q_start, q_end : float
        Process-noise variance on ``x`` per filter step at the start and the end of the run.
    P0 : float
        Initial variance of ``x``.
    sigmoid : SigmoidMap
        The constraint map (defaults a = 9000 kg, b = 5000 kg, c = 0.001).
    sensitivity : {"total", "partial"}
        See the module docstring.
    gate_probability : float or None
        Chi-square gate on the measurement's NIS (None: no gate).
    accel_bias : bool
        Also estimate the accelerometer bias (3 more states; the first three measurements read it).
    P0_accel_bias, q_accel_bias : float
        Its initial variance per axis ((m/s^2)^2) and random-walk variance per step.
    recovery : RecoveryPolicy
        When persistent gating or too-large innovations start a recovery (see :mod:`.filter`).
    """

    R_diag: np.ndarray
    q_start: float = 20.1
    q_end: float = 0.1
    P0: float = 100.0**2
    sigmoid: SigmoidMap = field(default_factory=SigmoidMap)
    sensitivity: str = "total"
    gate_probability: float | None = None
    accel_bias: bool = False
    P0_accel_bias: float = (50e-6 * 9.80665) ** 2
    q_accel_bias: float = 0.0
    recovery: RecoveryPolicy = field(default_factory=RecoveryPolicy)

    def __post_init__(self):
        if self.sensitivity not in ("total", "partial"):
            raise ValueError(f"sensitivity: expected 'total' or 'partial', found {self.sensitivity!r}")
        R = np.asarray(self.R_diag, dtype=float)
        if R.ndim != 1 or np.any(~np.isfinite(R)) or np.any(R <= 0):
            raise ValueError(f"R_diag: expected positive finite variances, found {R}")
        object.__setattr__(self, "R_diag", R)

    @classmethod
    def reference(cls, n_arm: int = 7, **overrides) -> "MassFilterTuning":
        """The reference's tuning: R = diag(1e-4 I3, 1e-2 I7), q from 20.1 to 0.1."""
        R = np.concatenate([np.full(3, 1e-4), np.full(n_arm, 1e-2)])
        return cls(R_diag=R, **overrides)


class MassFilter(FilterBase):
    """Scalar EKF on the sigmoid pre-image of the target mass (the stepper of :mod:`.filter`).

    Parameters
    ----------
    tuning : MassFilterTuning
    theta0 : float
        Initial mass estimate (kg), inside ``(b, a)``.
    t0, t_end : float
        Start and end of the run (s), for the process-noise schedule.
    name : str
    """

    def __init__(self, tuning: MassFilterTuning, theta0: float, t0: float, t_end: float, name: str = "mass"):
        self._init_base(name, tuning.recovery, tuning.gate_probability)
        self.tuning = tuning
        self.map = tuning.sigmoid
        self.nb = 3 if tuning.accel_bias else 0
        self.labels = ("mass_preimage",) + tuple(f"accel_bias_{a}" for a in "xyz")[: self.nb]
        self.s = np.zeros(1 + self.nb)  # [x, accelerometer bias (3)]
        self.s[0] = float(self.map.inverse(theta0))
        self.P = np.zeros((1 + self.nb, 1 + self.nb))
        self.P[0, 0] = float(tuning.P0)
        self.P[1:, 1:] = tuning.P0_accel_bias * np.eye(self.nb)
        self._P0 = self.P.copy()
        self.t0, self.t_end = float(t0), float(t_end)

    @property
    def x(self) -> float:
        """The sigmoid pre-image of the mass."""
        return float(self.s[0])

    @property
    def theta(self) -> float:
        """Mass estimate (kg)."""
        return float(self.map.forward(self.x))

    @property
    def sigma(self) -> float:
        """One-sigma of the mass estimate (kg), through the map's slope."""
        return float(abs(self.map.derivative(self.x)) * np.sqrt(self.P[0, 0]))

    @property
    def accel_bias(self) -> np.ndarray:
        """Accelerometer-bias estimate (m/s^2); zeros when not estimated."""
        return self.s[1:].copy() if self.nb else np.zeros(3)

    def process_noise(self, t: float) -> float:
        """Scheduled variance added per step at time ``t``."""
        span = max(self.t_end - self.t0, 1e-12)
        a = min(max((t - self.t0) / span, 0.0), 1.0)
        return self.tuning.q_start + a * (self.tuning.q_end - self.tuning.q_start)

    def predict(self, t: float, dt: float = 0.0, u=None) -> None:
        """Random-walk prediction of the mass (scheduled at ``t``) and of the bias (``dt``, ``u`` unused)."""
        self.P[0, 0] += self.process_noise(t)
        if self.nb:
            self.P[1:, 1:] += self.tuning.q_accel_bias * np.eye(self.nb)

    def update(self, z):
        """Correct with a linearised accelerations :class:`~postcapture.estimation.filter.Measurement`.

        ``z.value`` is the innovation ``z - z_hat`` of the plant copy's prediction (NaN = missing; the
        filter subtracts its own bias estimate) and ``z.H`` is ``dz/dtheta`` (m,). Returns the update
        result (with ``nis``), or None when no component was valid.
        """
        nu = np.array(z.value, dtype=float)
        dz = np.asarray(z.H, dtype=float)
        if self.nb:
            nu[:3] -= self.s[1:]
        ok = np.isfinite(nu) & np.isfinite(dz)
        if not ok.any():
            self.counts["measurements_missing"] += 1
            return None
        H = np.zeros((nu.size, 1 + self.nb))
        H[:, 0] = dz * self.map.derivative(self.x)
        if self.nb:
            H[:3, 1:] = np.eye(3)
        R = np.asarray(z.R, dtype=float)
        try:
            res = kalman.update(np.zeros(1 + self.nb), self.P, nu[ok], H[ok], R[np.ix_(ok, ok)],
                                gate_probability=self.gate(z.kind))
        except CovarianceError as exc:
            self.diverge(z.t, str(exc))
            return None
        if res.accepted:
            self.s = self.s + res.x
            # keep the pre-image where the sigmoid is not flat in floating point (|c x| < 30)
            limit = 30.0 / self.map.c
            self.s[0] = min(max(self.s[0], -limit), limit)
            self.P = res.P
        self.record(z.kind, z.t, res.nis, int(ok.sum()), res.accepted)
        self.check_covariance(z.t, "update")
        return res

    def _recover(self, kind: str, t: float) -> None:
        self.P = self.P * self.policy.inflation

    def _reinitialise(self, t: float) -> None:
        self.P = self._P0.copy()
