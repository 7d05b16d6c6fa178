r"""The model-based augmented EKF: plant state, sensor biases and plant parameters in one error state.

Error state (named by :attr:`AugmentedEKF.labels`)::

    [ dx (n: the plant's tangent) | db_gyro (3) | db_accel (3) | d gyro calibration (0 or 9) |
      d eta (estimated) | d eta (considered) | clone (9) ]

``eta`` are the filter's coordinates of the plant's parameters (:class:`~postcapture.estimation.
parameters.ParameterMap`: log-Cholesky for the target's inertial parameters, logarithms of factors).
Estimated coordinates are updated by the measurements; *considered* ones (Schmidt-Kalman) keep their
nominal value, but their covariance and their cross-covariance with everything else are carried, so the
filter's uncertainty covers what they do to the predictions. The gyro calibration (when the tuning gives
it a prior) is the three scale-factor errors and the six misalignments of the gyro triad (row-major
off-diagonal terms of ``M``; the gyro reads ``(I + diag(s) + M) omega``).

Prediction: the plant copy advances with the current parameters and its exact step Jacobians,
``Phi = [[F, G dp/deta], [0, I]]``; the biases are random walks; the plant's coordinates get the model
error process noise ``model_noise`` per step. Before the step, the chaser's attitude, linear velocity
and body rate (their errors and values) are *cloned* (stochastic cloning), so that the inertial sensors'
increments over the step (:mod:`postcapture.estimation.increments`: the mean rate and the mean specific
force, both exact functions of the clone and the predicted state) are ordinary measurements with exact
Jacobians.

Measurements: the star tracker (``H = I`` on the attitude), the gyro's mean rate (reads its bias and
calibration), the accelerometer's mean specific force at its position in B (reads its bias) and the arm's
encoders (``H = I`` on the joint angles).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from postcapture.core import kalman
from postcapture.core import rotations as rot
from postcapture.core.errors import CovarianceError, DomainError, SimulationError
from postcapture.estimation.filter import FilterBase, Measurement, RecoveryPolicy
from postcapture.core.triad import CALIBRATION_LABELS, calibration_matrix, calibration_sensitivity
from postcapture.estimation.increments import mean_rate, mean_specific_force, tidal_mean_B0
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
    P0_gyro_scale, P0_gyro_misalignment : float
        Prior variances of the gyro's scale-factor errors (relative) and misalignments (rad^2); both 0
        (the default): the filter carries no calibration states.
    mean_motion : float
        Of the orbit whose tidal field the accelerometer's model takes out (rad/s; 0: free space).
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
    P0_gyro_scale: float = 0.0
    P0_gyro_misalignment: float = 0.0
    mean_motion: float = 0.0
    gate_probability: float | None = 0.9999
    recovery: RecoveryPolicy = field(default_factory=RecoveryPolicy)

    @property
    def gyro_calibration(self) -> bool:
        """Whether the filter carries the gyro's scale factors and misalignments."""
        return self.P0_gyro_scale > 0.0 or self.P0_gyro_misalignment > 0.0



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
        ncal = 9 if tuning.gyro_calibration else 0
        self.i_bg = slice(n, n + 3)
        self.i_ba = slice(n + 3, n + 6)
        self.i_cal = slice(n + 6, n + 6 + ncal)
        e0 = n + 6 + ncal
        self.i_eta = slice(e0, e0 + k)
        self.i_est = slice(e0, e0 + k - n_consider)
        self.i_con = slice(e0 + k - n_consider, e0 + k)
        self.i_clone = slice(e0 + k, e0 + k + 9)
        N = self.i_clone.stop
        self.N = N
        # the cloned plant coordinates: attitude, linear velocity and body rate of the chaser
        self._cloned = np.r_[np.arange(self.att.start, self.att.stop),
                             np.arange(model.tangent_velocity.start, model.tangent_velocity.stop),
                             np.arange(model.tangent_rate.start, model.tangent_rate.stop)]
        self.i_arm = np.asarray(model.tangent_arm, dtype=int)
        self.r_accel = np.asarray(model.accelerometer_position, dtype=float)
        labels = [f"plant[{i}]" for i in range(n)]
        for i, axis in zip(range(self.att.start, self.att.stop), "xyz"):
            labels[i] = f"dtheta_{axis}"
        labels += [f"gyro_bias_{a}" for a in "xyz"] + [f"accel_bias_{a}" for a in "xyz"]
        if ncal:
            labels += [f"gyro_{label}" for label in CALIBRATION_LABELS]
        labels += list(params.labels)
        labels += [f"clone_{q}_{a}" for q in ("dtheta", "v", "omega") for a in "xyz"]
        self.labels = tuple(labels)
        self.eta = np.array(eta0, dtype=float)
        self._eta_init = self.eta.copy()
        self.gyro_bias = np.zeros(3)
        self.accel_bias = np.zeros(3)
        self.gyro_cal = np.zeros(ncal)
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
        if ncal:
            P[self.i_cal, self.i_cal] = np.diag([tuning.P0_gyro_scale] * 3 + [tuning.P0_gyro_misalignment] * 6)
        P[self.i_eta, self.i_eta] = P_eta
        Sx = S0 @ params.jacobian(self.eta)  # d x0 / d eta
        P[:n, :n] += Sx @ P_eta @ Sx.T
        P[:n, self.i_eta] = Sx @ P_eta
        P[self.i_eta, :n] = P[:n, self.i_eta].T
        self.P = kalman.symmetrize(P)
        self._P_init = self.P.copy()
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
        """Advance from ``t`` to ``t + dt`` (the known inputs are the model's own schedule; ``u`` is unused)."""
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
        self.P = kalman.symmetrize(P + Q)
        self.x = pred.x
        self._dt = dt
        self.t = t + dt
        self.check_covariance(self.t, "prediction")

    def _step(self, t, dt):
        J_eta = self.params.jacobian(self.eta)
        self.model.set_params(self.params.to_model(self.eta))
        return J_eta, self.model.predict(self.x, t, dt, jacobians=True)

    def _gyro_model(self):
        """The predicted gyro mean rate and its Jacobian (m = 3)."""
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
        """The predicted mean specific force at the accelerometer and its Jacobian (m = 3)."""
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
        """Correct with a star-tracker, gyro, accelerometer or encoder measurement; returns the update result or None.

        NaN entries of an accelerometer or encoder sample are missing and left out; a star-tracker or gyro
        sample with any NaN is missing.
        """
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
        self.gyro_cal = self.gyro_cal + dx[self.i_cal]
        self.eta = self.eta + dx[self.i_eta]
        c = self.i_clone.start
        q0, v0, w0 = self._clone
        self._clone = (rot.box_plus(q0, dx[c:c + 3]), v0 + dx[c + 3:c + 6], w0 + dx[c + 6:c + 9])

    # ------------------------------------------------------------------ faults
    def snapshot(self):
        """The filter's estimate and covariance, to :meth:`restore` (a fault found late is re-processed)."""
        return (self.x.copy(), self.P.copy(), self.gyro_bias.copy(), self.accel_bias.copy(), self.gyro_cal.copy(),
                self.eta.copy(), self._clone, self._dt, self.t)

    def restore(self, snap) -> None:
        """Back to a :meth:`snapshot`."""
        x, P, bg, ba, cal, eta, self._clone, self._dt, self.t = snap
        self.x, self.P, self.gyro_bias, self.accel_bias = x.copy(), P.copy(), bg.copy(), ba.copy()
        self.gyro_cal, self.eta = cal.copy(), eta.copy()

    def reopen_bias(self, sensor: str, axis: int, sigma: float) -> None:
        """Let a bias (the gyro's or the accelerometer's, on one axis) step now by ``sigma`` (1-sigma)."""
        index = (self.i_bg if sensor == "gyro" else self.i_ba).start + axis
        self.P[index, index] += sigma**2

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
        """Back to the prior: the initial parameters and covariance, the biases kept, the state as it is."""
        self.eta = self._eta_init.copy()
        self.P = self._P_init.copy()
