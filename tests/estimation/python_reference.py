"""The Python filters as they were before their arithmetic moved into the compiled engine (issue 19).

A test-only reference, kept verbatim in its arithmetic: the engine's filters must reproduce these estimates to
round-off on the same sensors (``test_engine_agreement.py``). Nothing under ``src`` imports it. Docstrings were
shortened; the numbers were not touched.
"""
# ruff: noqa
from __future__ import annotations

import logging
import math
from collections import deque
from functools import lru_cache

import numpy as np
from scipy.linalg.lapack import dpotrf, dpotrs
from scipy.stats import chi2

from postcapture.core import rotations as rot
from postcapture.core.errors import CovarianceError, DimensionError, DomainError, Problem, ScenarioError, SimulationError
from postcapture.core.units import DEG
from postcapture.estimation.filter import FilterEvent, FilterStatus, RecoveryPolicy
from postcapture.estimation.attitude_ekf import REACQUIRE_ATTITUDE
from postcapture.estimation.augmented import AugmentedEKF as _Engine
from postcapture.estimation.filter import FilterBase as _EngineBase
from postcapture.core.log_cholesky import _A
from postcapture.core.triad import CALIBRATION_LABELS, OFF_DIAGONAL, axis_matrix

ERROR_LABELS = ("dtheta_x", "dtheta_y", "dtheta_z", "dbias_x", "dbias_y", "dbias_z")

logger = logging.getLogger(__name__)


def symmetrize(P):
    return 0.5 * (P + P.T)


@lru_cache(maxsize=512)
def _chi2_quantile(probability: float, dim: int) -> float:
    return float(chi2.ppf(probability, dim))


class UpdateResult:
    def __init__(self, x, P, innovation, S, K, nis, accepted, threshold):
        self.x, self.P, self.innovation, self.S, self.K = x, P, innovation, S, K
        self.nis, self.accepted, self.threshold = nis, accepted, threshold


def update(x, P, innovation, H, R, *, gate_probability: float | None = None, consider=None) -> UpdateResult:
    x = np.asarray(x, dtype=float)
    nu = np.asarray(innovation, dtype=float)
    m = nu.size
    P, H, R = (np.asarray(a, dtype=float) for a in (P, H, R))
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
    threshold = None if gate_probability is None else _chi2_quantile(float(gate_probability), int(m))
    if threshold is not None and not nis <= threshold:
        return UpdateResult(x.copy(), P.copy(), nu, S, K, nis, False, threshold)
    # (I - K H) P (I - K H)^T, associated so that every product is n x n x m rather than n^3
    A = P - K @ (H @ P)
    P_new = symmetrize(A - (A @ H.T) @ K.T + K @ R @ K.T)
    return UpdateResult(x + K @ nu, P_new, nu, S, K, nis, True, threshold)




# ---------------------------------------------------------------- increments, triad, log-Cholesky
def mean_rate(q0_BN, q1_BN, dt: float):
    phi = rot.box_minus(q1_BN, q0_BN)
    return phi / dt, rot.right_jacobian_inv(phi) / dt, -rot.left_jacobian_inv(phi) / dt, phi


def mean_specific_force(phi, v0_B, w0_B, v1_B, w1_B, r_B, dt: float):
    E = rot.exp_matrix(phi)
    R = rot.skew(r_B)
    u0 = v0_B - R @ w0_B
    u1 = v1_B - R @ w1_B
    Eu1 = E @ u1
    J = {
        "att1": -(E @ rot.skew(u1)) / dt,
        "att0": rot.skew(Eu1) / dt,
        "v1": E / dt,
        "w1": -(E @ R) / dt,
        "v0": -np.eye(3) / dt,
        "w0": R / dt,
    }
    return (Eu1 - u0) / dt, J



def device_prediction(model, x0, x1, dt: float, S0, S1):
    q0, q1 = model.attitude(x0), model.attitude(x1)
    phi = rot.box_minus(q1, q0)
    f, J = mean_specific_force(phi, model.chaser_velocity(x0), model.body_rate(x0), model.chaser_velocity(x1),
                               model.body_rate(x1), model.accelerometer_position, dt)
    att, vel, rate = model.tangent_attitude, model.tangent_velocity, model.tangent_rate
    df = (J["att1"] @ S1[att] + J["v1"] @ S1[vel] + J["w1"] @ S1[rate]
          + J["att0"] @ S0[att] + J["v0"] @ S0[vel] + J["w0"] @ S0[rate])
    arm = model.tangent_arm
    return np.concatenate([f, model.arm_angles(x1)]), np.concatenate([df, S1[arm]])


def propagate(F, g, S):
    return F @ S + g


def lean(K, s_att):
    return s_att - K @ s_att


def mass_noise(s_rate, dt, sigma):
    d = np.asarray(s_rate) * dt * sigma
    return np.outer(d, d)


def tidal_mean_B0(q0_BN, r0_N, q1_BN, r1_N, r_B, mean_motion: float, t0: float, t1: float) -> np.ndarray:
    if not mean_motion:
        return np.zeros(3)
    n2 = mean_motion**2
    total = np.zeros(3)
    for q, r, t in ((q0_BN, r0_N, t0), (q1_BN, r1_N, t1)):
        p = np.asarray(r, dtype=float) + rot.dcm_from_quat(q).T @ np.asarray(r_B, dtype=float)
        z = np.array([np.cos(mean_motion * t), np.sin(mean_motion * t), 0.0])
        total += n2 * (3.0 * z * (z @ p) - p)
    return rot.dcm_from_quat(q0_BN) @ (0.5 * total)


def calibration_matrix(c) -> np.ndarray:
    M = np.zeros((3, 3))
    for v, (i, j) in zip(c[3:], OFF_DIAGONAL):
        M[i, j] = v
    return axis_matrix(c[:3], M)


def calibration_sensitivity(w) -> np.ndarray:
    D = np.zeros((3, 9))
    D[:, :3] = np.diag(w)
    for col, (i, j) in enumerate(OFF_DIAGONAL):
        D[i, 3 + col] = w[j]
    return D

def _U(theta) -> np.ndarray:
    a, d1, d2, d3, s12, s23, s13, t1, t2, t3 = np.asarray(theta, dtype=float)
    U = np.array([[np.exp(d1), s12, s13, t1], [0.0, np.exp(d2), s23, t2], [0.0, 0.0, np.exp(d3), t3],
                  [0.0, 0.0, 0.0, 1.0]])
    return np.exp(a) * U


def pi_from_theta(theta) -> np.ndarray:
    U = _U(theta)
    return _A @ (U @ U.T).reshape(16)


# where each off-diagonal coordinate of theta sits in U (flat index of the 4 x 4)
_OFF = {4: 1, 5: 6, 6: 2, 7: 3, 8: 7, 9: 11}


def dpi_dtheta(theta) -> np.ndarray:
    theta = np.asarray(theta, dtype=float)
    U = _U(theta)
    dU = np.zeros((10, 16))
    dU[0] = U.reshape(16)  # d U / d alpha = U
    for k in (1, 2, 3):
        dU[k, 5 * (k - 1)] = U[k - 1, k - 1]
    e = np.exp(theta[0])
    for k, flat in _OFF.items():
        dU[k, flat] = e
    G = dU.reshape(10, 4, 4) @ U.T  # dU U^T for every coordinate
    dJ = G + G.transpose(0, 2, 1)
    return (dJ.reshape(10, 16) @ _A.T).T

# ---------------------------------------------------------------- bookkeeping (estimation/filter.py)
@lru_cache(maxsize=256)
def _bound(dof: int, probability: float) -> float:
    return float(chi2.ppf(probability, dof))


class FilterBase:

    def _init_base(self, name: str, policy: RecoveryPolicy | None, gate_probability: float | None):
        _EngineBase._init_base(self, name, policy, gate_probability)  # name, status, events, policy, counts
        self._rejected_in_row: dict[str, int] = {}
        self._nis: dict[str, deque] = {}
        self._recoveries: deque = deque()
        self._reacquire: set[str] = set()

    # ------------------------------------------------------------------ gating and recovery
    def gate(self, kind: str) -> float | None:
        if kind in self._reacquire:
            return None
        return self.gate_probability

    def record(self, kind: str, t: float, nis: float, dof: int, accepted: bool) -> None:
        self._reacquire.discard(kind)
        if not accepted:
            self.counts["rejected"] += 1
            n = self._rejected_in_row.get(kind, 0) + 1
            self._rejected_in_row[kind] = n
            logger.info("%s: %s sample at t = %.6g s rejected (NIS %.3g)", self.name, kind, t, nis)
            if n >= self.policy.reject_limit:
                self._start_recovery(kind, t, f"{n} {kind} samples in a row rejected by the gate (last NIS {nis:.3g})")
            return
        self.counts["updates"] += 1
        self._rejected_in_row[kind] = 0
        window = self.policy.nis_window
        if not window:
            return
        buf = self._nis.setdefault(kind, deque(maxlen=window))
        buf.append((nis, dof))
        if len(buf) == window:
            total, dofs = sum(x for x, _ in buf), sum(d for _, d in buf)
            if total > _bound(dofs, self.policy.nis_probability):
                self._start_recovery(kind, t, f"{kind} innovations too large for their covariance (mean NIS "
                                              f"{total / window:.3g} over {window} updates, {dofs / window:g} dof each)")
            elif self.status is FilterStatus.RECOVERING:
                self.status = FilterStatus.RUNNING
                self.events.append(FilterEvent(t, "recovered", f"{kind} innovations consistent again"))

    def _start_recovery(self, kind: str, t: float, cause: str) -> None:
        self._rejected_in_row[kind] = 0
        self._nis.pop(kind, None)
        while self._recoveries and self._recoveries[0] < t - self.policy.recovery_window:
            self._recoveries.popleft()
        self._recoveries.append(t)
        if len(self._recoveries) > self.policy.max_recoveries:
            self.diverge(t, f"{len(self._recoveries)} recoveries within {self.policy.recovery_window:g} s; last: {cause}")
            return
        self.counts["recoveries"] += 1
        self.status = FilterStatus.RECOVERING
        self.events.append(FilterEvent(t, "recovering", cause))
        logger.warning("%s: recovering at t = %.6g s: %s", self.name, t, cause)
        self._recover(kind, t)

    def diverge(self, t: float, cause: str) -> None:
        self.counts["divergences"] += 1
        self.status = FilterStatus.DIVERGED
        self.events.append(FilterEvent(t, "diverged", cause))
        logger.error("%s diverged at t = %.6g s: %s", self.name, t, cause)
        self._recoveries.clear()
        self._nis.clear()
        self._reinitialise(t)
        self.events.append(FilterEvent(t, "reinitialised", "from the next measurements"))
        self.status = FilterStatus.RECOVERING
        self._reacquire.update(("star_tracker", "gyro", "accelerations"))

    def check_covariance(self, t: float, where: str) -> bool:
        P = self.P
        ok = bool(np.all(np.isfinite(P))) and bool(np.all(np.diag(P) >= 0.0))
        if not ok:
            self.diverge(t, f"covariance not finite or with a negative variance after the {where}")
        return ok

    # ------------------------------------------------------------------ hooks
    def _recover(self, kind: str, t: float) -> None:  # pragma: no cover - every filter overrides
        raise NotImplementedError

    def _reinitialise(self, t: float) -> None:  # pragma: no cover
        raise NotImplementedError


# ---------------------------------------------------------------- the parameter map's arithmetic (estimation/parameters.py)
def to_model(pmap, eta, p=None):
    out = (pmap.p_nominal if p is None else np.asarray(p, dtype=float)).copy()
    k = 0
    for b in pmap.blocks:
        n = len(b.labels)
        if b.group == "target":
            out[list(b.model_index)] = pi_from_theta(eta[k : k + n])
        else:
            out[list(b.model_index)] = np.exp(eta[k : k + n])
        k += n
    return out


def param_jacobian(pmap, eta):
    J = np.zeros((pmap.p_nominal.size, pmap.size))
    k = 0
    for b in pmap.blocks:
        n = len(b.labels)
        rows = list(b.model_index)
        if b.group == "target":
            J[np.ix_(rows, range(k, k + n))] = dpi_dtheta(eta[k : k + n])
        else:
            J[rows, range(k, k + n)] = np.exp(eta[k : k + n])
        k += n
    return J

# ---------------------------------------------------------------- MEKF (estimation/mekf.py)
def error_transition(omega_B, dt: float) -> np.ndarray:
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
    q11 = sigma_v**2 * dt + sigma_u**2 * dt**3 / 3.0
    q12 = -0.5 * sigma_u**2 * dt**2
    q22 = sigma_u**2 * dt
    return np.kron(np.array([[q11, q12], [q12, q22]]), np.eye(3))


class MEKF(FilterBase):

    labels = ERROR_LABELS

    def __init__(self, tuning: MEKFTuning, q0_BN, P0, *, bias0_B=None, t0: float = 0.0, recovery=None,
                 reacquire_bias: float = DEG):
        self._init_base(tuning.name, recovery, tuning.gate_probability)
        self.tuning = tuning
        self.q_BN = rot.normalize(_vec(q0_BN, "q0_BN", 4))
        self.bias_B = np.zeros(3) if bias0_B is None else _vec(bias0_B, "bias0_B", 3)
        P0 = np.asarray(P0, dtype=float)
        if P0.shape not in ((6, 6), (15, 15)):
            raise DimensionError(
                f"Incompatible dimensions of P0 matrix; expected (6, 6) or (15, 15) but found {P0.shape}"
            )
        self.m = P0.shape[0]
        self.labels = ERROR_LABELS + (tuple(f"d{label}" for label in CALIBRATION_LABELS) if self.m == 15 else ())
        self.calibration = np.zeros(self.m - 6)
        self._H = np.hstack([np.eye(3), np.zeros((3, self.m - 3))])
        self.P = symmetrize(P0)
        self._P0 = self.P.copy()
        self.t = float(t0)
        self.reacquire_bias = float(reacquire_bias)
        self.counts["inputs_missing"] = 0
        self._Q_cache: dict[float, np.ndarray] = {}
        try:
            np.linalg.cholesky(self.P)
        except np.linalg.LinAlgError:
            raise ScenarioError([Problem("MEKF.P0", "a positive definite (6, 6) covariance", repr(P0))]) from None

    def predict(self, t: float, dt: float, u) -> None:
        w = _vec(u, "u (gyro sample)", 3)
        if not np.all(np.isfinite(w)):
            raise ValueError("`u` must be finite; skip or hold missing gyro samples before calling predict")
        w = w - self.bias_B
        if self.m == 15:
            w = np.linalg.solve(calibration_matrix(self.calibration), w)
        self.q_BN = rot.box_plus(self.q_BN, w * dt)
        Q = self._Q_cache.get(dt)
        if Q is None:
            if len(self._Q_cache) > 64:  # irregular steps: keep the cache small
                self._Q_cache.clear()
            Q = np.zeros((self.m, self.m))
            Q[:6, :6] = process_noise(self.tuning.sigma_v, self.tuning.sigma_u, dt)
            self._Q_cache[dt] = Q
        Phi6 = error_transition(w, dt)
        if self.m == 15:
            Phi = np.eye(15)
            Phi[:6, :6] = Phi6
            Phi[:3, 6:] = Phi6[:3, 3:] @ calibration_sensitivity(w)
        else:
            Phi = Phi6
        self.P = symmetrize(Phi @ self.P @ Phi.T + Q)
        self.t = float(t) + dt
        self.check_covariance(self.t, "prediction")

    def update(self, z) -> UpdateResult | None:
        q = _vec(z.value, "star-tracker value", 4)
        if not np.all(np.isfinite(q)) or not np.linalg.norm(q) > 0:
            self.counts["measurements_missing"] += 1
            return None
        innovation = rot.box_minus(q, self.q_BN)
        try:
            res = update(np.zeros(self.m), self.P, innovation, self._H, z.R, gate_probability=self.gate(z.kind))
        except CovarianceError as exc:
            self.diverge(z.t, str(exc))
            return None
        if res.accepted:
            # reset: move the error into the attitude and the bias (the covariance reset Jacobian
            # I - [dtheta x]/2 differs from I at second order only, and is left out as usual)
            self.q_BN = rot.box_plus(self.q_BN, res.x[:3])
            self.bias_B = self.bias_B + res.x[3:6]
            self.calibration = self.calibration + res.x[6:]
            self.P = res.P
        self.record(z.kind, z.t, res.nis, 3, res.accepted)  # after the update: a recovery inflates the new P
        if res.accepted:
            self.check_covariance(z.t, "update")
        return res

    def snapshot(self):
        return self.q_BN.copy(), self.bias_B.copy(), self.calibration.copy(), self.P.copy(), self.t

    def restore(self, snap) -> None:
        q, b, c, P, self.t = snap
        self.q_BN, self.bias_B, self.calibration, self.P = q.copy(), b.copy(), c.copy(), P.copy()

    def reopen_bias(self, sensor: str, axis: int, sigma: float) -> None:
        self.P[3 + axis, 3 + axis] += sigma**2

    def _recover(self, kind: str, t: float) -> None:
        d = np.sqrt(self.policy.inflation)
        self.P = self.P * d * d
        self.P[3:6, 3:6] += self.policy.gyro_bias_bump**2 * np.eye(3)

    def _reinitialise(self, t: float) -> None:
        self.P = self._P0.copy()
        self.P[:3, :3] += REACQUIRE_ATTITUDE**2 * np.eye(3)  # lost: the next star-tracker sample decides
        self.P[3:6, 3:6] += self.reacquire_bias**2 * np.eye(3)


def _vec(v, name: str, n: int) -> np.ndarray:
    v = np.asarray(v, dtype=float)
    if v.shape != (n,):
        raise DimensionError(f"Incompatible dimensions of {name} vector; expected ({n},) but found {v.shape}")
    return v


# ---------------------------------------------------------------- attitude EKF
class AttitudeEKF(FilterBase):

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
        return self.model.attitude(self.x)

    def predict(self, t: float, dt: float, u=None) -> None:
        p = self.model.predict(self.x, t, dt, jacobians=True)
        Fa = p.F[self.att, self.att]
        Q = self.tuning.Q if self.extra_process_noise is None else self.tuning.Q + self.extra_process_noise
        self.P = symmetrize(Fa @ self.P @ Fa.T + Q)
        self.x = p.x
        self.last_prediction = p
        self.check_covariance(t + dt, "prediction")

    def update(self, z):
        q_meas = np.asarray(z.value, dtype=float)
        self.last_gain = np.zeros((3, 3))
        if not np.all(np.isfinite(q_meas)):
            self.counts["measurements_missing"] += 1
            return None
        innovation = rot.box_minus(q_meas, self.q_BN)
        try:
            res = update(np.zeros(3), self.P, innovation, np.eye(3), z.R, gate_probability=self.gate(z.kind))
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

# ---------------------------------------------------------------- mass filter
class MassFilter(FilterBase):

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
        return float(self.s[0])

    @property
    def theta(self) -> float:
        return float(self.map.forward(self.x))

    @property
    def sigma(self) -> float:
        return float(abs(self.map.derivative(self.x)) * np.sqrt(self.P[0, 0]))

    @property
    def accel_bias(self) -> np.ndarray:
        return self.s[1:].copy() if self.nb else np.zeros(3)

    def process_noise(self, t: float) -> float:
        span = max(self.t_end - self.t0, 1e-12)
        a = min(max((t - self.t0) / span, 0.0), 1.0)
        return self.tuning.q_start + a * (self.tuning.q_end - self.tuning.q_start)

    def predict(self, t: float, dt: float = 0.0, u=None) -> None:
        self.P[0, 0] += self.process_noise(t)
        if self.nb:
            self.P[1:, 1:] += self.tuning.q_accel_bias * np.eye(self.nb)

    def update(self, z):
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
            res = update(np.zeros(1 + self.nb), self.P, nu[ok], H[ok], R[np.ix_(ok, ok)],
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

# ---------------------------------------------------------------- augmented EKF
class AugmentedEKF(FilterBase):

    def __init__(self, model, x0, *, params: ParameterMap, n_consider: int, eta0, P_eta, S0, tuning: AugmentedTuning,
                 q0_BN=None, name: str = "joint"):
        self._init_base(name, tuning.recovery, tuning.gate_probability)
        self.model = model
        self.tuning = tuning
        self.params = params
        _Engine._layout(self, n_consider)  # indices, labels and the initial state: set-up, not the arithmetic
        self.x, self.eta, P, _, _ = _Engine._initial(self, x0, eta0, P_eta, S0, q0_BN)
        self._eta_init = self.eta.copy()
        self.gyro_bias = np.zeros(3)
        self.accel_bias = np.zeros(3)
        self.gyro_cal = np.zeros(self.i_cal.stop - self.i_cal.start)
        self.P = P
        self._P_init = self.P.copy()
        n, N = self.n, self.N
        self._cloned = np.r_[np.arange(self.att.start, self.att.stop),
                             np.arange(model.tangent_velocity.start, model.tangent_velocity.stop),
                             np.arange(model.tangent_rate.start, model.tangent_rate.stop)]
        self._clone = self._clone_values(self.x)
        self._dt = None
        nv = n // 2
        Q = np.zeros((N, N))
        noise = np.asarray(tuning.model_noise, dtype=float)
        if noise.ndim == 2:
            Q[:n, :n] = noise
        else:
            Q[range(nv, n), range(nv, n)] = np.broadcast_to(noise, (nv,))
        self._Q_rate = Q
        self.t = 0.0

    def _clone_values(self, x):
        m = self.model
        return m.attitude(x), m.chaser_velocity(x), m.body_rate(x)

    # ------------------------------------------------------------------ the stepper
    def predict(self, t: float, dt: float, u=None) -> None:
        tun = self.tuning
        try:
            J_eta, pred = self._step(t, dt)
        except (SimulationError, DomainError) as exc:  # the plant copy cannot take this step with these values
            self.diverge(t, f"the plant copy failed: {exc}")
            J_eta, pred = self._step(t, dt)
        # clone the chaser's attitude, velocity and rate at t (values and errors) before the step
        self._clone = self._clone_values(self.x)
        P = self.P
        c, a = self.i_clone, self._cloned
        P[c, :] = P[a, :]
        P[:, c] = P[:, a]
        n = self.n
        Phi_x = pred.F
        Phi_eta = pred.G @ J_eta
        # P <- Phi P Phi^T with Phi = I except the plant rows [F, G J]
        top = Phi_x @ P[:n, :] + Phi_eta @ P[self.i_eta, :]
        P[:n, :] = top
        left = P[:, :n] @ Phi_x.T + P[:, self.i_eta] @ Phi_eta.T
        P[:, :n] = left
        Q = self._Q_rate.copy()
        Q[self.i_bg, self.i_bg] = tun.sigma_gyro_bias_walk**2 * dt * np.eye(3)
        Q[self.i_ba, self.i_ba] = tun.sigma_accel_bias_walk**2 * dt * np.eye(3)
        self.P = symmetrize(P + Q)
        self.x = pred.x
        self._dt = dt
        self.t = t + dt
        self.check_covariance(self.t, "prediction")

    def _step(self, t, dt):
        J_eta = param_jacobian(self.params, self.eta)
        self.model.set_params(to_model(self.params, self.eta))
        return J_eta, self.model.predict(self.x, t, dt, jacobians=True)

    def _gyro_model(self):
        m, N, dt = self.model, self.N, self._dt
        w_bar, H1, H0, _ = mean_rate(self._clone[0], m.attitude(self.x), dt)
        C = np.eye(3)
        H = np.zeros((3, N))
        if self.gyro_cal.size:
            C = calibration_matrix(self.gyro_cal)
            H[:, self.i_cal] = calibration_sensitivity(w_bar)
        H[:, self.att] = C @ H1
        H[:, self.i_clone.start:self.i_clone.start + 3] = C @ H0
        H[:, self.i_bg] = np.eye(3)
        return C @ w_bar + self.gyro_bias, H

    def _accelerometer_model(self):
        m, N = self.model, self.N
        q0, v0, w0 = self._clone
        x = self.x
        phi = rot.box_minus(m.attitude(x), q0)
        f, J = mean_specific_force(phi, v0, w0, m.chaser_velocity(x), m.body_rate(x), self.r_accel, self._dt)
        if self.tuning.mean_motion:  # the reading is the acceleration less the tidal field (the cycle's end position)
            r1 = m.chaser_position(x)
            f = f - tidal_mean_B0(q0, r1, m.attitude(x), r1, self.r_accel, self.tuning.mean_motion,
                                  self.t - self._dt, self.t)
        H = np.zeros((3, N))
        H[:, self.att] = J["att1"]
        H[:, m.tangent_velocity] = J["v1"]
        H[:, m.tangent_rate] = J["w1"]
        c = self.i_clone.start
        H[:, c:c + 3] = J["att0"]
        H[:, c + 3:c + 6] = J["v0"]
        H[:, c + 6:c + 9] = J["w0"]
        H[:, self.i_ba] = np.eye(3)
        return f + self.accel_bias, H

    def update(self, z: Measurement):
        value = np.asarray(z.value, dtype=float)
        N = self.N
        ok = np.isfinite(value)
        if z.kind == "star_tracker":
            if not ok.all():
                self.counts["measurements_missing"] += 1
                return None
            nu = rot.box_minus(value, self.model.attitude(self.x))
            H = np.zeros((3, N))
            H[:, self.att] = np.eye(3)
            R = z.R
        elif z.kind in ("gyro", "accelerometer", "encoders"):
            if (z.kind == "gyro" and not ok.all()) or not ok.any():
                self.counts["measurements_missing"] += 1
                return None
            if z.kind == "gyro":
                z_hat, H = self._gyro_model()
            elif z.kind == "accelerometer":
                z_hat, H = self._accelerometer_model()
            else:
                z_hat = self.model.arm_angles(self.x)
                H = np.zeros((z_hat.size, N))
                H[np.arange(z_hat.size), self.i_arm] = 1.0
            nu = (value - z_hat)[ok]
            H = H[ok]
            R = np.asarray(z.R, dtype=float)[np.ix_(ok, ok)]
        else:
            raise ValueError("measurement kind: expected star_tracker, gyro, accelerometer or encoders, "
                             f"found {z.kind!r}")
        try:
            res = update(np.zeros(N), self.P, nu, H, R, gate_probability=self.gate(z.kind), consider=self.i_con)
        except CovarianceError as exc:
            self.diverge(z.t, f"{z.kind} update: {exc}")
            return None
        if res.accepted:
            self._apply(res.x)
            self.P = res.P
        self.record(z.kind, z.t, res.nis, nu.size, res.accepted)  # after the update: a recovery inflates the new P
        return res

    def _apply(self, dx) -> None:
        n = self.n
        self.x = self.model.retract(self.x, dx[:n])
        self.gyro_bias = self.gyro_bias + dx[self.i_bg]
        self.accel_bias = self.accel_bias + dx[self.i_ba]
        self.gyro_cal = self.gyro_cal + dx[self.i_cal]
        self.eta = self.eta + dx[self.i_eta]
        c = self.i_clone.start
        q0, v0, w0 = self._clone
        self._clone = (rot.box_plus(q0, dx[c:c + 3]), v0 + dx[c + 3:c + 6], w0 + dx[c + 6:c + 9])

    # ------------------------------------------------------------------ faults
    def snapshot(self):
        return (self.x.copy(), self.P.copy(), self.gyro_bias.copy(), self.accel_bias.copy(), self.gyro_cal.copy(),
                self.eta.copy(), self._clone, self._dt, self.t)

    def restore(self, snap) -> None:
        x, P, bg, ba, cal, eta, self._clone, self._dt, self.t = snap
        self.x, self.P, self.gyro_bias, self.accel_bias = x.copy(), P.copy(), bg.copy(), ba.copy()
        self.gyro_cal, self.eta = cal.copy(), eta.copy()

    def reopen_bias(self, sensor: str, axis: int, sigma: float) -> None:
        index = (self.i_bg if sensor == "gyro" else self.i_ba).start + axis
        self.P[index, index] += sigma**2

    # ------------------------------------------------------------------ outputs
    @property
    def q_BN(self) -> np.ndarray:
        return self.model.attitude(self.x)

    def parameters(self) -> np.ndarray:
        return to_model(self.params, self.eta)

    def parameter_covariance(self) -> np.ndarray:
        J = param_jacobian(self.params, self.eta)
        return J @ self.P[self.i_eta, self.i_eta] @ J.T

    # ------------------------------------------------------------------ recovery
    def _inflate(self, index) -> None:
        d = np.ones(self.N)
        d[index] = np.sqrt(self.policy.inflation)
        self.P = self.P * np.outer(d, d)

    def _recover(self, kind: str, t: float) -> None:
        nv = self.n // 2
        bias_g = np.arange(self.i_bg.start, self.i_bg.stop)
        if kind == "star_tracker":
            self._inflate(np.r_[np.arange(self.att.start, self.att.stop), bias_g])
            self.P[self.i_bg, self.i_bg] += self.policy.gyro_bias_bump**2 * np.eye(3)
        elif kind == "gyro":
            self._inflate(np.r_[np.arange(nv + 3, nv + 6), bias_g])
            self.P[self.i_bg, self.i_bg] += self.policy.gyro_bias_bump**2 * np.eye(3)
        elif kind == "encoders":  # the arm's angles and rates
            self._inflate(np.r_[self.i_arm, self.i_arm + nv])
        else:  # the accelerometer: the plant's velocities and its bias; a transient the model misses (a torque
            # step ringing the arm) is the state's to absorb, not a reason to forget the mass
            self._inflate(np.r_[np.arange(nv, self.n), np.arange(self.i_ba.start, self.i_ba.stop)])

    def _reinitialise(self, t: float) -> None:
        self.eta = self._eta_init.copy()
        self.P = self._P_init.copy()
