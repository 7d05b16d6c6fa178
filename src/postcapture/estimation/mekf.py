r"""Multiplicative extended Kalman filter (Lefferts, Markley and Shuster) for attitude and gyro bias.

The filter carries the attitude ``q_BN`` and the gyro bias ``b`` as its state, and a 6-component
error state ``dx = (dtheta_B, db)`` with covariance ``P``: ``dtheta_B = box_minus(q_true, q_est)`` is
a right (body-frame) perturbation as in :mod:`postcapture.core.rotations`, ``db = b_true - b_est``.
Gyro samples drive the propagation; star-tracker quaternions correct it, and after every update the
error is moved into ``q`` and ``b`` (the *reset*) so that the error state is zero again.

Between two instants ``dt`` apart the estimated rate ``w = omega_meas - b_est`` is held constant, so
``q <- box_plus(q, w dt)`` is exact and the error-state transition has the closed form

.. math::

    \Phi = \begin{bmatrix} e^{-[w\times] dt} & -\int_0^{dt} e^{-[w\times] s} ds \\ 0 & I \end{bmatrix},\qquad
    Q = \begin{bmatrix} (\sigma_v^2 dt + \sigma_u^2 dt^3/3) I & -\sigma_u^2 dt^2/2\, I \\
                        -\sigma_u^2 dt^2/2\, I & \sigma_u^2 dt\, I \end{bmatrix}.

References
----------
E. J. Lefferts, F. L. Markley, M. D. Shuster, "Kalman filtering for spacecraft attitude estimation",
J. Guidance, Control, and Dynamics 5(5), 1982. F. L. Markley, J. L. Crassidis, *Fundamentals of
Spacecraft Attitude Determination and Control*, Springer, 2014, sections 6.2.4 and 6.4.
"""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass
from functools import lru_cache

import numpy as np

from postcapture.core import kalman
from postcapture.core import rotations as rot
from postcapture.core.errors import (
    CovarianceError,
    DimensionError,
    FilterDivergenceError,
    Problem,
    ScenarioError,
    TimeGridError,
)
from postcapture.core.timegrid import default_tolerance, merge_times
from postcapture.estimation.history import EstimateHistory, SampledSignal, StepFlag

__all__ = [
    "MEKFTuning",
    "MEKF",
    "run_mekf",
    "error_transition",
    "process_noise",
]

logger = logging.getLogger(__name__)

_H = np.hstack([np.eye(3), np.zeros((3, 3))])
ERROR_LABELS = ("dtheta_x", "dtheta_y", "dtheta_z", "dbias_x", "dbias_y", "dbias_z")


@dataclass(frozen=True, slots=True)
class MEKFTuning:
    """Noise model and safeguards of the MEKF.

    Parameters
    ----------
    sigma_v : float
        Gyro angle random walk assumed by the filter (rad/sqrt(s)).
    sigma_u : float
        Gyro bias random walk assumed by the filter (rad/s^1.5).
    star_covariance : array_like, shape (3, 3)
        Star-tracker rotation-error covariance in body components (rad^2).
    gate_probability : float or None
        Chi-square gate on the star-tracker NIS (3 degrees of freedom); None switches gating off.
    max_consecutive_rejections : int
        This many gated-out measurements in a row mean the filter has lost the attitude: divergence.
    name : str
        Name used in logs and errors.
    """

    sigma_v: float
    sigma_u: float
    star_covariance: np.ndarray
    gate_probability: float | None = 0.9999
    max_consecutive_rejections: int = 20
    name: str = "mekf"

    def __post_init__(self):
        problems = []

        def bad(key, expected, found):
            problems.append(Problem(f"MEKFTuning.{key}", expected, repr(found)))

        for key in ("sigma_v", "sigma_u"):
            v = getattr(self, key)
            try:
                ok = math.isfinite(float(v)) and float(v) >= 0
            except (TypeError, ValueError):
                ok = False
            if not ok:
                bad(key, "a finite number >= 0", v)
            else:
                object.__setattr__(self, key, float(v))
        R = np.array(self.star_covariance, dtype=float)
        if R.shape != (3, 3) or not np.all(np.isfinite(R)) or not np.allclose(R, R.T):
            bad("star_covariance", "a finite symmetric (3, 3) array", R)
        elif np.min(np.linalg.eigvalsh(R)) <= 0:
            bad("star_covariance", "a positive definite array", R)
        p = self.gate_probability
        if p is not None and not (isinstance(p, (float, np.floating)) and 0.0 < p < 1.0):
            bad("gate_probability", "None or a number in (0, 1)", p)
        m = self.max_consecutive_rejections
        if isinstance(m, bool) or not isinstance(m, (int, np.integer)) or m < 1:
            bad("max_consecutive_rejections", "an integer >= 1", m)
        if problems:
            raise ScenarioError(problems, source="MEKFTuning")
        R.setflags(write=False)
        object.__setattr__(self, "star_covariance", R)


def error_transition(omega_B, dt: float) -> np.ndarray:
    """Closed-form error-state transition ``Phi`` (6, 6) over ``dt`` (s).

    Parameters
    ----------
    omega_B : array_like, shape (3,)
        Estimated body rate ``omega_meas - b_est`` (rad/s), held constant over the step.
    dt : float
        Step (s).
    """
    w = np.asarray(omega_B, dtype=float)
    a2 = float(w @ w)
    a = math.sqrt(a2)
    W = rot.skew(w)
    W2 = np.outer(w, w) - a2 * np.eye(3)  # [w x]^2
    th = a * dt
    if th < 1e-4:  # Taylor series of the coefficients
        c1, c2 = dt * (1.0 - th * th / 6.0), dt * dt * (0.5 - th * th / 24.0)
        c3 = dt**3 * (1.0 / 6.0 - th * th / 120.0)
    else:
        s, c = math.sin(th), math.cos(th)
        c1, c2, c3 = s / a, (1.0 - c) / a2, (th - s) / (a2 * a)
    Phi = np.eye(6)
    Phi[:3, :3] += c2 * W2 - c1 * W
    Phi[:3, 3:] = c2 * W - c3 * W2
    Phi[[0, 1, 2], [3, 4, 5]] -= dt
    return Phi


def process_noise(sigma_v: float, sigma_u: float, dt: float) -> np.ndarray:
    """Discrete process-noise covariance (6, 6) of the attitude/bias error over ``dt`` (s).

    Parameters
    ----------
    sigma_v : float
        Angle random walk (rad/sqrt(s)).
    sigma_u : float
        Bias random walk (rad/s^1.5).
    dt : float
        Step (s).
    """
    q11 = sigma_v**2 * dt + sigma_u**2 * dt**3 / 3.0
    q12 = -0.5 * sigma_u**2 * dt**2
    q22 = sigma_u**2 * dt
    return np.kron(np.array([[q11, q12], [q12, q22]]), np.eye(3))


@lru_cache(maxsize=16)
def _threshold(probability: float, dim: int) -> float:
    return kalman.gate_threshold(probability, dim)


class MEKF:
    """Stepper: propagate with gyro samples, correct with star-tracker quaternions.

    Parameters
    ----------
    tuning : MEKFTuning
        Noise model and safeguards.
    q0_BN : array_like, shape (4,)
        Initial attitude estimate.
    P0 : array_like, shape (6, 6)
        Initial error covariance (rad^2 and (rad/s)^2).
    bias0_B : array_like, shape (3,), optional
        Initial gyro-bias estimate (rad/s); zero by default.
    t0 : float
        Initial time (s).
    raise_on_divergence : bool
        Raise :class:`FilterDivergenceError` on divergence (default); otherwise mark the filter failed
        (``status == "failed"``, ``message``) and refuse further steps.
    """

    def __init__(self, tuning: MEKFTuning, q0_BN, P0, *, bias0_B=None, t0: float = 0.0,
                 raise_on_divergence: bool = True):
        self.tuning = tuning
        self.name = tuning.name
        self.q_BN = rot.normalize(_vec(q0_BN, "q0_BN", 4))
        self.bias_B = np.zeros(3) if bias0_B is None else _vec(bias0_B, "bias0_B", 3)
        P0 = np.asarray(P0, dtype=float)
        if P0.shape != (6, 6):
            raise DimensionError(
                f"Incompatible dimensions of P0 matrix; expected (6, 6) but found {P0.shape}"
            )
        self.P = kalman.symmetrize(P0)
        self.t = float(t0)
        self.raise_on_divergence = raise_on_divergence
        self.status = "running"
        self.message = ""
        self.cause = ""
        self.counts = {"updates": 0, "rejected": 0, "measurements_missing": 0, "inputs_missing": 0}
        self._consecutive_rejections = 0
        self._Q_cache: dict[float, np.ndarray] = {}
        self._threshold = None if tuning.gate_probability is None else _threshold(tuning.gate_probability, 3)
        self._check_covariance("initial covariance")

    # -- lifecycle -------------------------------------------------------------------------------
    def _diverge(self, cause: str) -> None:
        self.status = "failed"
        self.cause = cause
        self.message = f"filter {self.name!r} diverged at t = {self.t:.6g} s: {cause}"
        logger.error(self.message)
        if self.raise_on_divergence:
            raise FilterDivergenceError(self.name, self.t, cause)

    def _ensure_running(self) -> None:
        if self.status != "running":
            raise RuntimeError(f"Attempt to step the failed filter {self.name!r}: {self.message}")

    def _check_covariance(self, where: str) -> bool:
        if not np.all(np.isfinite(self.P)):
            self._diverge(f"{where}: covariance P is not finite")
            return False
        try:
            np.linalg.cholesky(self.P)
        except np.linalg.LinAlgError:
            self._diverge(f"{where}: covariance P is not positive definite")
            return False
        return True

    # -- steps -----------------------------------------------------------------------------------
    def predict(self, dt: float, omega_meas_B, *, t: float | None = None) -> None:
        """Propagate over ``dt`` (s) with a gyro sample ``omega_meas_B`` (3,) (rad/s) held constant.

        ``t`` sets the time reached (s) instead of accumulating ``t + dt``.
        """
        self._ensure_running()
        w = _vec(omega_meas_B, "omega_meas_B", 3)
        if not np.all(np.isfinite(w)):
            raise ValueError(
                "`omega_meas_B` must be finite; skip or hold missing gyro samples before calling predict"
            )
        w = w - self.bias_B
        self.q_BN = rot.box_plus(self.q_BN, w * dt)
        Q = self._Q_cache.get(dt)
        if Q is None:
            if len(self._Q_cache) > 64:  # irregular steps: keep the cache small
                self._Q_cache.clear()
            Q = self._Q_cache[dt] = process_noise(self.tuning.sigma_v, self.tuning.sigma_u, dt)
        Phi = error_transition(w, dt)
        _, self.P = kalman.predict(np.zeros(6), self.P, Phi, Q)
        self.t = self.t + dt if t is None else float(t)
        self._check_covariance("prediction")

    def update(self, q_meas_BN, R=None) -> kalman.UpdateResult | None:
        """Correct with a star-tracker quaternion (4,); ``R`` (3, 3) overrides ``tuning.star_covariance``.

        Returns the kernel's :class:`~postcapture.core.kalman.UpdateResult`, or None when the sample
        is not finite (skipped and counted) or the filter diverged here (``raise_on_divergence=False``).
        A sample rejected by the gate leaves the state unchanged (``result.accepted`` is False).
        """
        self._ensure_running()
        q = _vec(q_meas_BN, "q_meas_BN", 4)
        if not np.all(np.isfinite(q)) or not np.linalg.norm(q) > 0:
            self.counts["measurements_missing"] += 1
            return None
        innovation = rot.box_minus(q, self.q_BN)
        R = self.tuning.star_covariance if R is None else R
        try:
            res = kalman.update(np.zeros(6), self.P, innovation, _H, R)
        except CovarianceError as exc:
            self._diverge(str(exc))
            return None
        if not math.isfinite(res.nis):
            self._diverge("innovation is not finite")
            return None
        if self._threshold is not None and res.nis > self._threshold:
            self.counts["rejected"] += 1
            self._consecutive_rejections += 1
            logger.warning(
                "%s: star-tracker sample at t = %.6g s rejected by the chi-square gate (NIS %.4g > %.4g)",
                self.name, self.t, res.nis, self._threshold,
            )
            if self._consecutive_rejections >= self.tuning.max_consecutive_rejections:
                angle = float(np.linalg.norm(innovation))
                self._diverge(
                    f"{self._consecutive_rejections} consecutive star-tracker samples rejected by the "
                    f"innovation gate (last NIS {res.nis:.3g}, innovation angle {angle:.3g} rad)"
                )
                return None
            return kalman.UpdateResult(
                np.zeros(6), self.P, innovation, res.S, res.K, res.nis, False, self._threshold
            )
        self._consecutive_rejections = 0
        self.counts["updates"] += 1
        # reset: move the error into the attitude and the bias (the covariance reset Jacobian
        # I - [dtheta x]/2 differs from I at second order only, and is left out as usual)
        self.q_BN = rot.box_plus(self.q_BN, res.x[:3])
        self.bias_B = self.bias_B + res.x[3:]
        self.P = res.P
        self._check_covariance("update")
        return res


def _vec(v, name: str, n: int) -> np.ndarray:
    v = np.asarray(v, dtype=float)
    if v.shape != (n,):
        raise DimensionError(f"Incompatible dimensions of {name} vector; expected ({n},) but found {v.shape}")
    return v


def run_mekf(t, gyro: SampledSignal, star: SampledSignal, tuning: MEKFTuning, q0_BN, P0, *,
             bias0_B=None, raise_on_divergence: bool = True) -> EstimateHistory:
    """Run the MEKF through recorded gyro and star-tracker samples and record it at the instants ``t``.

    Parameters
    ----------
    t : array_like, shape (n,)
        Output instants (s), strictly increasing; the filter starts at ``t[0]`` with ``q0_BN``, ``P0``.
    gyro : SampledSignal
        Gyro record: ``t`` (n_g,), ``values`` (3, n_g) (rad/s), ``valid`` (n_g,). Sample ``k`` drives the
        propagation from its instant to the next one; a missing sample is replaced by the last valid one
        (counted in ``counts["inputs_missing"]``, flag ``INPUT_MISSING``).
    star : SampledSignal
        Star-tracker record: ``t`` (n_s,), ``values`` (4, n_s) measured ``q_BN``, ``valid`` (n_s,). Samples
        may fall anywhere in ``[t[0], t[-1]]``; missing or non-finite ones are skipped and counted.
    tuning : MEKFTuning
        Noise model and safeguards.
    q0_BN : array_like, shape (4,)
        Initial attitude estimate at ``t[0]``.
    P0 : array_like, shape (6, 6)
        Initial error covariance.
    bias0_B : array_like, shape (3,), optional
        Initial bias estimate (rad/s), zero by default.
    raise_on_divergence : bool
        If False, a divergence ends the run early and the history carries ``success=False``,
        ``status=-1`` and the message; later columns are NaN and flagged ``DIVERGED``.

    Returns
    -------
    EstimateHistory
        ``q_BN`` (4, n), ``P`` (6, 6, n), ``states["gyro_bias_B"]`` (3, n), ``nis`` and ``flags``
        at the output instants, after the update made there.

    Raises
    ------
    FilterDivergenceError
        On divergence (covariance not finite or not positive definite, or too many consecutive gated
        samples), naming the filter, the time and the cause; unless ``raise_on_divergence=False``.
    DimensionError, TimeGridError
        On malformed inputs, or when no gyro sample precedes ``t[0]``.
    """
    t = np.asarray(t, dtype=float)
    if t.ndim != 1 or t.size == 0 or np.any(np.diff(t) <= 0):
        raise DimensionError("`t` must be a non-empty, strictly increasing 1-D array")
    g_t, g_val = np.asarray(gyro.t, dtype=float), np.asarray(gyro.values, dtype=float)
    s_t, s_val = np.asarray(star.t, dtype=float), np.asarray(star.values, dtype=float)
    if g_val.shape != (3, g_t.size) or s_val.shape != (4, s_t.size):
        raise DimensionError(f"gyro values must be (3, {g_t.size}) and star values (4, {s_t.size}); "
                             f"found {g_val.shape} and {s_val.shape}")
    tol = default_tolerance(t, g_t, s_t)
    if g_t.size == 0 or g_t[0] > t[0] + tol:
        raise TimeGridError(f"{tuning.name}: no gyro sample at or before t[0] = {t[0]:.6g} s")
    g_ok = np.asarray(gyro.valid, dtype=bool) & np.all(np.isfinite(g_val), axis=0)
    s_ok = np.asarray(star.valid, dtype=bool) & np.all(np.isfinite(s_val), axis=0)
    s_in = (s_t >= t[0] - tol) & (s_t <= t[-1] + tol)
    g_in = (g_t >= t[0] - tol) & (g_t <= t[-1] + tol)
    events, (ev_out, _, ev_star) = merge_times(t, g_t[g_in], s_t[s_in], tol=tol)
    gyro_at = np.searchsorted(g_t, events + tol, side="right") - 1  # sample in effect from each event on
    last_ok = np.maximum.accumulate(np.where(g_ok, np.arange(g_t.size), -1))
    star_idx = np.flatnonzero(s_in)
    star_at = np.full(events.size, -1)
    star_at[ev_star] = star_idx
    out_at = np.full(events.size, -1)
    out_at[ev_out] = np.arange(t.size)

    n = t.size
    q_hist, b_hist = np.full((4, n), np.nan), np.full((3, n), np.nan)
    P_hist, nis_hist = np.full((6, 6, n), np.nan), np.full(n, np.nan)
    flags = np.zeros(n, dtype=np.uint8)
    f = MEKF(tuning, q0_BN, P0, bias0_B=bias0_B, t0=events[0], raise_on_divergence=raise_on_divergence)
    f.counts["inputs_missing"] = int(np.count_nonzero(~g_ok[g_in]))
    pending, nis_now, diverged_at = StepFlag.NONE, np.nan, None
    for e in range(events.size):
        if e > 0:
            k = gyro_at[e - 1]
            if not g_ok[k]:
                pending |= StepFlag.INPUT_MISSING
                k = last_ok[k]
            omega = g_val[:, k] if k >= 0 else f.bias_B  # nothing valid yet: assume zero rate
            f.predict(events[e] - events[e - 1], omega, t=events[e])
        s = star_at[e]
        if s >= 0 and f.status == "running":
            if not s_ok[s]:
                pending |= StepFlag.MEASUREMENT_MISSING
                f.counts["measurements_missing"] += 1
            else:
                res = f.update(s_val[:, s])
                if res is not None:
                    nis_now = res.nis
                    pending |= StepFlag.UPDATED if res.accepted else StepFlag.REJECTED
        if f.status != "running":
            diverged_at = np.searchsorted(t, events[e] - tol)
            break
        o = out_at[e]
        if o >= 0:
            q_hist[:, o], b_hist[:, o], P_hist[:, :, o] = f.q_BN, f.bias_B, f.P
            nis_hist[o], flags[o] = nis_now, pending
            pending, nis_now = StepFlag.NONE, np.nan
    success = diverged_at is None
    if not success:
        flags[diverged_at:] |= np.uint8(StepFlag.DIVERGED)
    return EstimateHistory(
        filter_name=tuning.name, t=t, q_BN=q_hist, P=P_hist, nis=nis_hist, flags=flags,
        error_labels=ERROR_LABELS, states={"gyro_bias_B": b_hist}, counts=dict(f.counts),
        success=success, status=0 if success else -1, message="completed" if success else f.message,
    )
