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

The arithmetic (the schedule, the update, the clamp, the recovery) runs in the compiled engine
(``pc_mass_filter.c``); the map's inverse, used once to start, is :class:`~postcapture.core.sigmoid.SigmoidMap`'s.
"""

from __future__ import annotations

import ctypes
from dataclasses import dataclass, field

import numpy as np

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
        self.t0, self.t_end = float(t0), float(t_end)
        m = self.map
        self._attach(self._eng.massf_create(self.nb, float(m.inverse(theta0)), float(tuning.P0),
                                            float(tuning.P0_accel_bias), float(tuning.q_start), float(tuning.q_end),
                                            float(tuning.q_accel_bias), m.a, m.b, m.c, self.t0, self.t_end,
                                            ctypes.byref(self._policy(tuning.R_diag.size))))
        n = 1 + self.nb
        self._s, self._P = self._state[:n], self._state[n:].reshape(n, n)

    @property
    def s(self) -> np.ndarray:
        """The state: the sigmoid pre-image of the mass, then the accelerometer bias (when estimated)."""
        return self._s.copy()

    @property
    def x(self) -> float:
        """The sigmoid pre-image of the mass."""
        return float(self._s[0])

    def estimate(self) -> tuple[float, float]:
        """The mass estimate and its one-sigma (kg), through the map's slope (the engine's)."""
        theta, sigma = ctypes.c_double(), ctypes.c_double()
        self._eng.massf_estimate(self._handle, ctypes.byref(theta), ctypes.byref(sigma))
        return theta.value, sigma.value

    @property
    def theta(self) -> float:
        """Mass estimate (kg)."""
        return self.estimate()[0]

    @property
    def sigma(self) -> float:
        """One-sigma of the mass estimate (kg), through the map's slope."""
        return self.estimate()[1]

    @property
    def accel_bias(self) -> np.ndarray:
        """Accelerometer-bias estimate (m/s^2); zeros when not estimated."""
        return self._s[1:].copy() if self.nb else np.zeros(3)

    def process_noise(self, t: float) -> float:
        """Scheduled variance added per step at time ``t``."""
        return float(self._eng.massf_noise(self._handle, float(t)))

    def predict(self, t: float, dt: float = 0.0, u=None) -> None:
        """Random-walk prediction of the mass (its variance scheduled at ``t``) and of the bias (``dt``, ``u``
        unused)."""
        self._eng.massf_predict(self._handle, float(t))

    def update(self, z):
        """Correct with a linearised accelerations :class:`~postcapture.estimation.filter.Measurement`.

        ``z.value`` is the innovation ``z - z_hat`` of the plant copy's prediction (NaN = missing; the
        filter subtracts its own bias estimate) and ``z.H`` is ``dz/dtheta`` (m,). Returns the update
        result (with ``nis``), or None when no component was valid.
        """
        nu = np.ascontiguousarray(z.value, dtype=float)
        self._eng.massf_update(self._handle, float(z.t), nu.size, nu, np.ascontiguousarray(z.H, dtype=float),
                               np.ascontiguousarray(z.R, dtype=float), ctypes.byref(self._res))
        return self._result(z.kind, z.t)
