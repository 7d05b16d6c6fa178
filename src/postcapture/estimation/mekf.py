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

With a 15 x 15 ``P0`` the filter also estimates the gyro's calibration, the three scale-factor errors
``s`` and the six misalignments ``m`` of ``omega_meas = (I + diag(s) + M) omega + b + noise`` (Markley and
Crassidis, section 6.4.1): the rate is ``w = (I + diag(s) + M)^-1 (omega_meas - b)``, its error is
``-db - D dc`` with ``D = [diag(w), the misalignment's columns]``, and the attitude error's column for the
calibration is the bias column times ``D``. The calibration terms are constants.

References
----------
E. J. Lefferts, F. L. Markley, M. D. Shuster, "Kalman filtering for spacecraft attitude estimation",
J. Guidance, Control, and Dynamics 5(5), 1982. F. L. Markley, J. L. Crassidis, *Fundamentals of
Spacecraft Attitude Determination and Control*, Springer, 2014, sections 6.2.4 and 6.4.
"""

from __future__ import annotations

import ctypes
import logging
import math
from dataclasses import dataclass

import numpy as np

from postcapture.core import rotations as rot
from postcapture.core.kalman import UpdateResult
from postcapture.core.errors import (
    DimensionError,
    FilterDivergenceError,
    Problem,
    ScenarioError,
    TimeGridError,
)
from postcapture.core.timegrid import default_tolerance, merge_times
from postcapture.core.units import DEG
from postcapture.estimation.attitude_ekf import REACQUIRE_ATTITUDE
from postcapture.estimation.filter import FilterBase, Measurement, state_view
from postcapture.estimation.history import EstimateHistory, SampledSignal, StepFlag
from postcapture.core.triad import CALIBRATION_LABELS
from postcapture.dynamics import engine as _engine

__all__ = [
    "MEKFTuning",
    "MEKF",
    "run_mekf",
    "error_transition",
    "process_noise",
]

logger = logging.getLogger(__name__)

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
    name : str
        Name used in logs and errors.
    """

    sigma_v: float
    sigma_u: float
    star_covariance: np.ndarray
    gate_probability: float | None = 0.9999
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
        if problems:
            raise ScenarioError(problems, source="MEKFTuning")
        R.setflags(write=False)
        object.__setattr__(self, "star_covariance", R)


def error_transition(omega_B, dt: float) -> np.ndarray:
    """Closed-form error-state transition ``Phi`` (6, 6) over ``dt`` (s), computed by the engine.

    Parameters
    ----------
    omega_B : array_like, shape (3,)
        Estimated body rate ``omega_meas - b_est`` (rad/s), held constant over the step.
    dt : float
        Step (s).
    """
    Phi = np.zeros((6, 6))
    _engine.engine().mekf_transition(np.ascontiguousarray(omega_B, dtype=float), float(dt), Phi)
    return Phi


def process_noise(sigma_v: float, sigma_u: float, dt: float) -> np.ndarray:
    """Discrete process-noise covariance (6, 6) of the attitude/bias error over ``dt`` (s), computed by the engine.

    Parameters
    ----------
    sigma_v : float
        Angle random walk (rad/sqrt(s)).
    sigma_u : float
        Bias random walk (rad/s^1.5).
    dt : float
        Step (s).
    """
    Q = np.zeros((6, 6))
    _engine.engine().mekf_noise(float(sigma_v), float(sigma_u), float(dt), Q)
    return Q


class MEKF(FilterBase):
    """Stepper: propagate with gyro samples, correct with star-tracker quaternions (see :mod:`.filter`).

    The arithmetic runs in the compiled engine (``pc_mekf.c``); this object holds its configuration and
    exposes its state.

    Parameters
    ----------
    tuning : MEKFTuning
        Noise model and safeguards.
    q0_BN : array_like, shape (4,)
        Initial attitude estimate.
    P0 : array_like, shape (6, 6) or (15, 15)
        Initial error covariance (rad^2 and (rad/s)^2); (15, 15) also estimates the gyro calibration
        (see the module docstring).
    bias0_B : array_like, shape (3,), optional
        Initial gyro-bias estimate (rad/s); zero by default.
    t0 : float
        Initial time (s).
    recovery : RecoveryPolicy, optional
        When a run of star-tracker innovations says the covariance no longer covers the error (a gyro
        bias step, a lost attitude), the attitude and bias covariances are inflated and the bias gets
        a one-off bump of the policy's ``gyro_bias_bump`` (rad/s, 1 deg/h by default) per axis; see
        :mod:`.filter`.
    reacquire_bias : float
        1-sigma of the bias after a divergence, when the filter starts again from the next star-tracker
        samples (rad/s); by default 1 deg/s (the attitude is lost: the bias may be anything).
    """

    labels = ERROR_LABELS

    def __init__(self, tuning: MEKFTuning, q0_BN, P0, *, bias0_B=None, t0: float = 0.0, recovery=None,
                 reacquire_bias: float = DEG):
        self._init_base(tuning.name, recovery, tuning.gate_probability)
        self.tuning = tuning
        q0 = _vec(q0_BN, "q0_BN", 4)
        bias0 = np.zeros(3) if bias0_B is None else _vec(bias0_B, "bias0_B", 3)
        P0 = np.asarray(P0, dtype=float)
        if P0.shape not in ((6, 6), (15, 15)):
            raise DimensionError(
                f"Incompatible dimensions of P0 matrix; expected (6, 6) or (15, 15) but found {P0.shape}"
            )
        self.m = m = P0.shape[0]
        self.labels = ERROR_LABELS + (tuple(f"d{label}" for label in CALIBRATION_LABELS) if m == 15 else ())
        try:
            np.linalg.cholesky(0.5 * (P0 + P0.T))
        except np.linalg.LinAlgError:
            raise ScenarioError([Problem("MEKF.P0", "a positive definite (6, 6) covariance", repr(P0))]) from None
        self.reacquire_bias = float(reacquire_bias)
        self.counts["inputs_missing"] = 0
        self._attach(self._eng.mekf_create(m, np.ascontiguousarray(q0), np.ascontiguousarray(bias0),
                                           np.ascontiguousarray(P0), float(t0), tuning.sigma_v, tuning.sigma_u,
                                           REACQUIRE_ATTITUDE, self.reacquire_bias, ctypes.byref(self._policy(3))))
        st = self._state
        self._q, self._b, self._c = st[0:4], st[4:7], st[7:m + 1]
        self._t = st[m + 1:m + 2]
        self._P = st[m + 2:].reshape(m, m)
        # a step's gyro sample, star-tracker sample and covariance are copied into these (allocated once: their
        # addresses are taken once)
        self._in_w, self._in_q, self._in_R = np.zeros(3), np.zeros(4), np.zeros((3, 3))
        self._addr.update(w=self._in_w.ctypes.data, q=self._in_q.ctypes.data, R=self._in_R.ctypes.data)
        self._predict_call = self._eng.by_address("mekf_predict")
        self._update_call = self._eng.by_address("mekf_update")

    # ------------------------------------------------------------------ the state (the engine's)
    @property
    def q_BN(self) -> np.ndarray:
        """Attitude estimate (scalar first)."""
        return self._q.copy()

    @q_BN.setter
    def q_BN(self, value) -> None:
        self._q[:] = rot.normalize(_vec(value, "q_BN", 4))

    bias_B = state_view("_b", "Gyro-bias estimate (rad/s).")
    calibration = state_view("_c", "Gyro scale-factor and misalignment estimates (9; none with 6 states).")

    @property
    def t(self) -> float:
        """Time of the estimate (s)."""
        return float(self._t[0])

    @t.setter
    def t(self, value: float) -> None:
        self._t[0] = float(value)

    # ------------------------------------------------------------------ the stepper
    def predict(self, t: float, dt: float, u) -> None:
        """Propagate from ``t`` over ``dt`` (s) with the gyro sample ``u`` (3,) (rad/s) held constant."""
        w = _vec(u, "u (gyro sample)", 3)
        if not np.all(np.isfinite(w)):
            raise ValueError("`u` must be finite; skip or hold missing gyro samples before calling predict")
        self._in_w[...] = w
        self._predict_call(self._handle, float(t), float(dt), self._addr["w"])
        self._sync()

    def update(self, z) -> UpdateResult | None:
        """Correct with a star-tracker :class:`~postcapture.estimation.filter.Measurement` (4,).

        Returns the kernel's :class:`~postcapture.core.kalman.UpdateResult`, or None when the sample is
        not finite (skipped and counted). A sample rejected by the gate leaves the state unchanged.
        """
        self._in_q[...] = _vec(z.value, "star-tracker value", 4)
        self._in_R[...] = _vec(np.ravel(z.R), "star-tracker covariance", 9).reshape(3, 3)
        addr = self._addr
        self._update_call(self._handle, float(z.t), addr["q"], addr["R"], addr["res"])
        return self._result(z.kind, z.t)

    def reopen_bias(self, sensor: str, axis: int, sigma: float) -> None:
        """Let the gyro bias on one axis (``sensor`` is ``"gyro"``) step now by ``sigma`` (1-sigma)."""
        self._P[3 + axis, 3 + axis] += sigma**2


def _vec(v, name: str, n: int) -> np.ndarray:
    v = np.asarray(v, dtype=float)
    if v.shape != (n,):
        raise DimensionError(f"Incompatible dimensions of {name} vector; expected ({n},) but found {v.shape}")
    return v


def run_mekf(t, gyro: SampledSignal, star: SampledSignal, tuning: MEKFTuning, q0_BN, P0, *,
             bias0_B=None, raise_on_divergence: bool = True, recovery=None) -> EstimateHistory:
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
        Raise after the run if the filter diverged; otherwise the history carries ``success=False``,
        ``status=-1``, the message, and the flag ``DIVERGED`` from the divergence on (the filter
        re-initialises there and goes on).
    recovery : RecoveryPolicy, optional

    Returns
    -------
    EstimateHistory
        ``q_BN`` (4, n), ``P`` (6, 6, n), ``states["gyro_bias_B"]`` (3, n), ``nis`` and ``flags``
        at the output instants, after the update made there.

    Raises
    ------
    FilterDivergenceError
        On divergence (covariance not finite or not positive definite, or recoveries that did not
        help), naming the filter, the time and the cause; unless ``raise_on_divergence=False``.
    DimensionError, TimeGridError
        On malformed inputs, or when no gyro sample precedes ``t[0]``.
    """
    t = np.asarray(t, dtype=float)
    if t.ndim != 1 or t.size == 0 or np.any(np.diff(t) <= 0):
        raise DimensionError("`t` must be a non-empty, strictly increasing 1-D array")
    plan = _schedule(t, gyro, star, tuning.name)
    f = MEKF(tuning, q0_BN, P0, bias0_B=bias0_B, t0=plan.events[0], recovery=recovery)
    f.counts["inputs_missing"] = plan.inputs_missing
    q_hist, b_hist, P_hist, nis_hist, flags = _run_events(f, plan, tuning, t.size)
    success, message = _outcome(f, t, plan.tol, flags, raise_on_divergence)
    return EstimateHistory(
        filter_name=tuning.name, t=t, q_BN=q_hist, P=P_hist, nis=nis_hist, flags=flags,
        error_labels=ERROR_LABELS, states={"gyro_bias_B": b_hist}, counts=dict(f.counts),
        success=success, status=0 if success else -1, message=message, events=tuple(f.events),
    )


@dataclass(frozen=True, slots=True)
class _Schedule:
    """The instants :func:`run_mekf` stops at, in time order, and what happens at each (-1: nothing)."""

    events: np.ndarray  # the output, gyro and star-tracker instants merged (s)
    tol: float  # time tolerance of the merge (s)
    gyro_at: np.ndarray  # the gyro sample in effect from each event on
    last_ok: np.ndarray  # per gyro sample, the last valid one at or before it (-1: none yet)
    star_at: np.ndarray  # the star-tracker sample at each event
    out_at: np.ndarray  # the output instant at each event
    g_val: np.ndarray  # gyro values (3, n_g) (rad/s)
    g_ok: np.ndarray  # gyro samples valid and finite (n_g,)
    s_val: np.ndarray  # star-tracker values (4, n_s)
    s_ok: np.ndarray  # star-tracker samples valid and finite (n_s,)
    inputs_missing: int  # invalid gyro samples within the output span


def _schedule(t: np.ndarray, gyro: SampledSignal, star: SampledSignal, name: str) -> _Schedule:
    """Check the records against the output instants ``t`` and merge the three into one event list."""
    g_t, g_val = np.asarray(gyro.t, dtype=float), np.asarray(gyro.values, dtype=float)
    s_t, s_val = np.asarray(star.t, dtype=float), np.asarray(star.values, dtype=float)
    if g_val.shape != (3, g_t.size) or s_val.shape != (4, s_t.size):
        raise DimensionError(f"gyro values must be (3, {g_t.size}) and star values (4, {s_t.size}); "
                             f"found {g_val.shape} and {s_val.shape}")
    tol = default_tolerance(t, g_t, s_t)
    if g_t.size == 0 or g_t[0] > t[0] + tol:
        raise TimeGridError(f"{name}: no gyro sample at or before t[0] = {t[0]:.6g} s")
    g_ok = np.asarray(gyro.valid, dtype=bool) & np.all(np.isfinite(g_val), axis=0)
    s_ok = np.asarray(star.valid, dtype=bool) & np.all(np.isfinite(s_val), axis=0)
    s_in = (s_t >= t[0] - tol) & (s_t <= t[-1] + tol)
    g_in = (g_t >= t[0] - tol) & (g_t <= t[-1] + tol)
    events, (ev_out, _, ev_star) = merge_times(t, g_t[g_in], s_t[s_in], tol=tol)
    gyro_at = np.searchsorted(g_t, events + tol, side="right") - 1  # sample in effect from each event on
    last_ok = np.maximum.accumulate(np.where(g_ok, np.arange(g_t.size), -1))
    star_at = np.full(events.size, -1)
    star_at[ev_star] = np.flatnonzero(s_in)
    out_at = np.full(events.size, -1)
    out_at[ev_out] = np.arange(t.size)
    return _Schedule(events=events, tol=tol, gyro_at=gyro_at, last_ok=last_ok, star_at=star_at, out_at=out_at,
                     g_val=g_val, g_ok=g_ok, s_val=s_val, s_ok=s_ok,
                     inputs_missing=int(np.count_nonzero(~g_ok[g_in])))


def _run_events(f: MEKF, plan: _Schedule, tuning: MEKFTuning, n: int):
    """Step the filter through every event, recording it at the ``n`` output instants:
    ``(q (4, n), bias (3, n), P (6, 6, n), nis (n,), flags (n,))``."""
    q_hist, b_hist = np.full((4, n), np.nan), np.full((3, n), np.nan)
    P_hist, nis_hist = np.full((6, 6, n), np.nan), np.full(n, np.nan)
    flags = np.zeros(n, dtype=np.uint8)
    pending, nis_now = StepFlag.NONE, np.nan
    for e in range(plan.events.size):
        if e > 0:
            pending = _propagate(f, plan, e, pending)
        pending, nis_now = _correct(f, plan, e, tuning, pending, nis_now)
        o = plan.out_at[e]
        if o >= 0:
            q_hist[:, o], b_hist[:, o], P_hist[:, :, o] = f.q_BN, f.bias_B, f.P
            nis_hist[o], flags[o] = nis_now, pending
            pending, nis_now = StepFlag.NONE, np.nan
    return q_hist, b_hist, P_hist, nis_hist, flags


def _propagate(f: MEKF, plan: _Schedule, e: int, pending: StepFlag) -> StepFlag:
    """Propagate from event ``e - 1`` to ``e`` with the gyro sample in effect (the last valid one if it is
    missing); returns ``pending`` with what happened."""
    k = plan.gyro_at[e - 1]
    if not plan.g_ok[k]:
        pending |= StepFlag.INPUT_MISSING
        k = plan.last_ok[k]
    omega = plan.g_val[:, k] if k >= 0 else f.bias_B  # nothing valid yet: assume zero rate
    f.predict(plan.events[e - 1], plan.events[e] - plan.events[e - 1], omega)
    return pending


def _correct(f: MEKF, plan: _Schedule, e: int, tuning: MEKFTuning, pending: StepFlag, nis_now: float):
    """Correct with the star-tracker sample at event ``e``, if any; returns ``(pending, nis_now)`` updated."""
    s = plan.star_at[e]
    if s < 0:
        return pending, nis_now
    if not plan.s_ok[s]:
        f.counts["measurements_missing"] += 1
        return pending | StepFlag.MEASUREMENT_MISSING, nis_now
    res = f.update(Measurement("star_tracker", plan.events[e], plan.s_val[:, s], tuning.star_covariance))
    if res is not None:
        nis_now = res.nis
        pending |= StepFlag.UPDATED if res.accepted else StepFlag.REJECTED
    return pending, nis_now


def _outcome(f: MEKF, t: np.ndarray, tol: float, flags: np.ndarray, raise_on_divergence: bool):
    """``(success, message)`` of the run; on divergence flag ``DIVERGED`` from there on, or raise."""
    diverged = [e for e in f.events if e.kind == "diverged"]
    if not diverged:
        return True, "completed"
    flags[np.searchsorted(t, diverged[0].t - tol):] |= np.uint8(StepFlag.DIVERGED)
    if raise_on_divergence:
        raise FilterDivergenceError(f.name, diverged[0].t, diverged[0].cause)
    return False, f"filter {f.name!r} diverged at t = {diverged[0].t:.6g} s: {diverged[0].cause}"
