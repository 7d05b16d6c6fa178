r"""The model-based augmented EKF: plant state, sensor biases and plant parameters in one error state.

Error state (named by :attr:`AugmentedEKF.labels`)::

    [ dx (n: the plant's tangent) | db_gyro (3) | db_accel (3) | d eta (estimated) |
      d eta (considered) | d theta_clone (3) ]

``eta`` are the filter's coordinates of the plant's parameters (:class:`~postcapture.estimation.
parameters.ParameterMap`: log-Cholesky for the target's inertial parameters, logarithms of factors).
Estimated coordinates are updated by the measurements; *considered* ones (Schmidt-Kalman) keep their
nominal value, but their covariance and their cross-covariance with everything else are carried, so the
filter's uncertainty covers what they do to the predictions.

Prediction: the plant copy advances with the current parameters and its exact step Jacobians,
``Phi = [[F, G dp/deta], [0, I]]``; the biases are random walks; the plant's velocities get the model
error process noise ``model_noise`` per step. Before the step, the attitude error is *cloned* (stochastic
cloning) so that the gyro's delta-angle over the step, ``box_minus(q_k+1, q_k) / dt + b``, is an ordinary
measurement of the clone and the current attitude (``H = [Jr^-1 / dt on the attitude, -Jl^-1 / dt on the
clone, I on the bias]``, the exact first-order derivative of the box-minus).

Measurements: the star tracker (``H = I`` on the attitude), the gyro, and the accelerations
``[accelerometer (3, reads its bias), arm joint accelerations]`` with ``H = [H_x, I_bias, Hp dp/deta]``.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from postcapture.core import kalman
from postcapture.core import rotations as rot
from postcapture.core.errors import CovarianceError, DomainError, SimulationError
from postcapture.estimation.filter import FilterBase, Measurement, RecoveryPolicy
from postcapture.estimation.parameters import ParameterMap

__all__ = ["AugmentedTuning", "AugmentedEKF"]


@dataclass(frozen=True)
class AugmentedTuning:
    """Noise model of the augmented EKF (SI units; variances per axis unless stated).

    Parameters
    ----------
    R_star : ndarray (3, 3)
        Star-tracker covariance (rad^2).
    sigma_gyro_bias_walk : float
        Gyro bias random walk (rad/s^1.5).
    sigma_accel_bias_walk : float
        Accelerometer bias random walk (m/s^2.5).
    P0_attitude : ndarray (3, 3)
    P0_gyro_bias, P0_accel_bias : float
    P0_state : float
        Initial variance of every other plant coordinate, on top of what the parameters imply.
    model_noise : float, ndarray (nv,) or ndarray (n, n)
        Process noise added per step to the plant: one variance for every velocity coordinate, one per
        velocity coordinate ((rad/s)^2 or (m/s)^2), or a full covariance over the plant's tangent: the
        model error the parameters do not describe.
    gate_probability : float or None
    recovery : RecoveryPolicy
    """

    R_star: np.ndarray
    sigma_gyro_bias_walk: float
    sigma_accel_bias_walk: float
    P0_attitude: np.ndarray
    P0_gyro_bias: float
    P0_accel_bias: float
    P0_state: float = 1e-16
    model_noise: float | np.ndarray = 0.0
    gate_probability: float | None = 0.9999
    recovery: RecoveryPolicy = field(default_factory=RecoveryPolicy)


class AugmentedEKF(FilterBase):
    """See the module docstring.

    Parameters
    ----------
    model : ProcessModel
        The filter's own plant copy (with ``param_names``, ``params``, ``set_params`` and ``G``, ``Hp``).
    x0 : ndarray (nx,)
        Initial plant state, for the nominal parameters ``model.params``.
    params : ParameterMap
        Coordinates of the estimated groups followed by the considered ones.
    n_consider : int
        How many of ``params``' last coordinates are considered.
    eta0 : ndarray
        Initial coordinates (estimated and considered).
    P_eta : ndarray
        Their initial covariance.
    S0 : ndarray (n, n_p)
        Derivative of the initial plant state with respect to the parameters (``x0 = x0(p)``).
    tuning : AugmentedTuning
    q0_BN : ndarray (4,), optional
        Initial attitude estimate (replaces ``x0``'s).
    name : str
    """

    def __init__(self, model, x0, *, params: ParameterMap, n_consider: int, eta0, P_eta, S0, tuning: AugmentedTuning,
                 q0_BN=None, name: str = "joint"):
        self._init_base(name, tuning.recovery, tuning.gate_probability)
        self.model = model
        self.tuning = tuning
        self.params = params
        n = model.n
        self.n = n
        self.att = model.tangent_attitude
        k = params.size
        self.i_bg = slice(n, n + 3)
        self.i_ba = slice(n + 3, n + 6)
        self.i_eta = slice(n + 6, n + 6 + k)
        self.i_est = slice(n + 6, n + 6 + k - n_consider)
        self.i_con = slice(n + 6 + k - n_consider, n + 6 + k)
        self.i_clone = slice(n + 6 + k, n + 9 + k)
        N = self.i_clone.stop
        self.N = N
        labels = [f"plant[{i}]" for i in range(n)]
        for i, axis in zip(range(self.att.start, self.att.stop), "xyz"):
            labels[i] = f"dtheta_{axis}"
        labels += [f"gyro_bias_{a}" for a in "xyz"] + [f"accel_bias_{a}" for a in "xyz"]
        labels += list(params.labels) + [f"clone_{a}" for a in "xyz"]
        self.labels = tuple(labels)
        self.eta = np.array(eta0, dtype=float)
        self._eta_init = self.eta.copy()
        self.gyro_bias = np.zeros(3)
        self.accel_bias = np.zeros(3)
        x = np.array(x0, dtype=float)
        if q0_BN is not None:
            d = np.zeros(n)
            d[self.att] = rot.box_minus(np.asarray(q0_BN, dtype=float), model.attitude(x))
            x = model.retract(x, d)
        # the initial state follows the parameters it was computed with: move it to eta0, first order
        p0 = params.to_model(self.eta)
        model.set_params(p0)
        self.x = model.retract(x, S0 @ (p0 - params.p_nominal))
        P = np.zeros((N, N))
        P[:n, :n] = tuning.P0_state * np.eye(n)
        P[self.att, self.att] = tuning.P0_attitude
        P[self.i_bg, self.i_bg] = tuning.P0_gyro_bias * np.eye(3)
        P[self.i_ba, self.i_ba] = tuning.P0_accel_bias * np.eye(3)
        P[self.i_eta, self.i_eta] = P_eta
        Sx = S0 @ params.jacobian(self.eta)  # d x0 / d eta
        P[:n, :n] += Sx @ P_eta @ Sx.T
        P[:n, self.i_eta] = Sx @ P_eta
        P[self.i_eta, :n] = P[:n, self.i_eta].T
        self.P = kalman.symmetrize(P)
        self._P_init = self.P.copy()
        self._q_clone = model.attitude(self.x)
        self._pred = None
        self._p_pred = None
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

    # ------------------------------------------------------------------ the stepper
    def predict(self, t: float, dt: float, u=None) -> None:
        """Advance from ``t`` to ``t + dt`` (the known inputs are the model's own schedule; ``u`` is unused)."""
        model, tun = self.model, self.tuning
        try:
            J_eta, p, pred = self._step(t, dt)
        except (SimulationError, DomainError) as exc:  # the plant copy cannot take this step with these values
            self.diverge(t, f"the plant copy failed: {exc}")
            J_eta, p, pred = self._step(t, dt)
        # clone the attitude at t (value and error) before the step
        self._q_clone = model.attitude(self.x)
        P = self.P
        c, a = self.i_clone, self.att
        P[c, :] = P[a, :]
        P[:, c] = P[:, a]
        P[c, c] = P[a, a]
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
        self.P = kalman.symmetrize(P + Q)
        self.x = pred.x
        self._pred, self._p_pred, self._J_eta, self._dt = pred, p, J_eta, dt
        self.t = t + dt
        self.check_covariance(self.t, "prediction")

    def _step(self, t, dt):
        J_eta = self.params.jacobian(self.eta)
        p = self.params.to_model(self.eta)
        self.model.set_params(p)
        return J_eta, p, self.model.predict(self.x, t, dt, jacobians=True)

    def update(self, z: Measurement):
        """Correct with a star-tracker, gyro or accelerations measurement; returns the update result or None."""
        value = np.asarray(z.value, dtype=float)
        N, n = self.N, self.n
        if z.kind == "star_tracker":
            if not np.all(np.isfinite(value)):
                self.counts["measurements_missing"] += 1
                return None
            nu = rot.box_minus(value, self.model.attitude(self.x))
            H = np.zeros((3, N))
            H[:, self.att] = np.eye(3)
            R = z.R
        elif z.kind == "gyro":
            if not np.all(np.isfinite(value)):
                self.counts["measurements_missing"] += 1
                return None
            dt = self._dt
            phi = rot.box_minus(self.model.attitude(self.x), self._q_clone)
            nu = value - phi / dt - self.gyro_bias
            H = np.zeros((3, N))
            H[:, self.att] = rot.right_jacobian_inv(phi) / dt
            H[:, self.i_clone] = -rot.left_jacobian_inv(phi) / dt
            H[:, self.i_bg] = np.eye(3)
            R = z.R
        elif z.kind == "accelerations":
            ok = np.isfinite(value)
            if not ok.any():
                self.counts["measurements_missing"] += 1
                return None
            pred = self._pred
            dp = self.params.to_model(self.eta) - self._p_pred
            z_hat = pred.z + pred.H @ self.model.local(self.x, pred.x) + pred.Hp @ dp
            z_hat[:3] += self.accel_bias
            H = np.zeros((value.size, N))
            H[:, :n] = pred.H
            H[:3, self.i_ba] = np.eye(3)
            H[:, self.i_eta] = pred.Hp @ self._J_eta
            nu = (value - z_hat)[ok]
            H = H[ok]
            R = np.asarray(z.R, dtype=float)[np.ix_(ok, ok)]
        else:
            raise ValueError(f"measurement kind: expected star_tracker, gyro or accelerations, found {z.kind!r}")
        try:
            res = kalman.update(np.zeros(N), self.P, nu, H, R, gate_probability=self.gate(z.kind), consider=self.i_con)
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
        self.eta = self.eta + dx[self.i_eta]
        self._q_clone = rot.box_plus(self._q_clone, dx[self.i_clone])

    # ------------------------------------------------------------------ outputs
    @property
    def q_BN(self) -> np.ndarray:
        """Attitude estimate (scalar first)."""
        return self.model.attitude(self.x)

    def parameters(self) -> np.ndarray:
        """The estimated parameter vector of the plant (its ``param_names``)."""
        return self.params.to_model(self.eta)

    def parameter_covariance(self) -> np.ndarray:
        """Covariance of the plant's parameter vector, first order through ``dp / d eta``."""
        J = self.params.jacobian(self.eta)
        return J @ self.P[self.i_eta, self.i_eta] @ J.T

    # ------------------------------------------------------------------ recovery
    def _inflate(self, index) -> None:
        d = np.ones(self.N)
        d[index] = np.sqrt(self.policy.inflation)
        self.P = self.P * np.outer(d, d)

    def _recover(self, kind: str, t: float) -> None:
        nv = self.n // 2
        if kind == "star_tracker":
            self._inflate(np.r_[np.arange(self.att.start, self.att.stop), np.arange(self.i_bg.start, self.i_bg.stop)])
            self.P[self.i_bg, self.i_bg] += self.policy.gyro_bias_bump**2 * np.eye(3)
        elif kind == "gyro":
            self._inflate(np.r_[np.arange(nv + 3, nv + 6), np.arange(self.i_bg.start, self.i_bg.stop)])
            self.P[self.i_bg, self.i_bg] += self.policy.gyro_bias_bump**2 * np.eye(3)
        else:  # the accelerations: the plant's velocities and the accelerometer bias; a transient the model
            # misses (a torque step ringing the arm) is the state's to absorb, not a reason to forget the mass
            self._inflate(np.r_[np.arange(nv, self.n), np.arange(self.i_ba.start, self.i_ba.stop)])

    def _reinitialise(self, t: float) -> None:
        """Back to the prior: the initial parameters and covariance, the biases kept, the state as it is."""
        self.eta = self._eta_init.copy()
        self.P = self._P_init.copy()
