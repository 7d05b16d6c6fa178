"""Cramer-Rao lower bound of the target mass, with the model's uncertain parameters as nuisance.

The unknowns are ``theta = (c, gyro bias (3), accelerometer bias (3), initial attitude (3))``, where ``c``
are coordinates of the plant's parameter vector along the directions ``D = dp/dc`` (n_p x k): the mass
alone for a *known model*, or every parameter the scenario declares uncertain (in the filters' own
coordinates) *with nuisance*. Along the true trajectory the plant's sensitivity ``S_k = dx_k/dc``
follows the exact step Jacobians, ``S_k+1 = F_k S_k + G_k D`` from ``S_0 = (dx_0/dp) D`` (the initial
state is computed from the parameters). Each measurement's sensitivity follows:

- star tracker: ``S_k[att]`` and ``I`` on the initial attitude (to first order);
- gyro mean rate over ``[t_k, t_k+1]``: ``(Jr^-1 S_k+1[att] - Jl^-1 S_k[att]) / dt`` and ``I`` on its bias;
- accelerometer mean specific force over ``[t_k, t_k+1]`` (:mod:`.increments`): its Jacobians with respect
  to the chaser's attitude, velocity and rate at both ends times their sensitivities, and ``I`` on its bias;
- encoders: ``S_k+1`` on the arm's joint angles.

The Fisher information ``J = J_prior + sum_k G_k^T R^-1 G_k`` (``J_prior`` the inverse of the declared
priors: the Bayesian bound) gives the bound ``sqrt(g^T J^-1 g)`` with ``g = dm/dtheta``: no estimator of
the mass, knowing the plant up to those nuisance parameters and their priors, does better on the same
data. It is given for all sensors, for each alone and for the accelerations together, and as a history
(the bound from the data up to each instant), which shows the excitation the mass information comes from.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from postcapture.core import rotations as rot
from postcapture.estimation.increments import calibration_sensitivity, mean_specific_force

__all__ = ["MassCRLB", "mass_crlb"]


@dataclass
class MassCRLB:
    """One-sigma bounds on the mass (kg) from each sensor and from all of them (None: not computed), and over time."""

    all_sensors: float
    star_tracker: float | None
    gyro: float | None
    accelerometer: float | None
    joints: float | None  # the encoders
    accelerations_only: float | None  # accelerometer and encoders together
    history: np.ndarray = field(default_factory=lambda: np.zeros(0))  # all sensors, data up to each instant

    def as_dict(self) -> dict:
        """Plain dict of the bounds (kg), for JSON (the history is left out)."""
        return {k: v for k, v in self.__dict__.items() if k != "history"}


def _bound(J: np.ndarray, g: np.ndarray) -> float:
    """``sqrt(g^T J^-1 g)`` with a pseudo-inverse guard for unidentifiable nuisance directions."""
    try:
        val = float(g @ np.linalg.solve(J, g))
    except np.linalg.LinAlgError:
        val = float(g @ np.linalg.pinv(J) @ g)
    return float(np.sqrt(val)) if val > 0 else float("inf")


def mass_crlb(model, x0, dx0_dp, t_grid, *, directions, mass_gradient, R_star, sigma_gyro: float, R_accel,
              prior_information=None, bias_priors=None, calibration_priors=None, progress=None) -> MassCRLB:
    """Cramer-Rao bound of the target mass along the trajectory the model runs from ``x0``.

    Parameters
    ----------
    model : ProcessModel
        The truth's model (with its true parameters set).
    x0 : ndarray (nx,)
        Its initial state.
    dx0_dp : ndarray (n, n_p)
        Derivative of the initial state with respect to the model's parameter vector.
    t_grid : ndarray (n_t,)
        Uniform sample instants of every sensor.
    directions : ndarray (n_p, k)
        ``dp/dc``: the parameter coordinates the bound is over.
    mass_gradient : ndarray (k,)
        ``dm/dc`` of the total target mass.
    R_star : ndarray (3, 3)
        Star-tracker covariance (rad^2).
    sigma_gyro : float
        One-sigma noise of a gyro sample (rad/s).
    R_accel : ndarray (m,)
        Variances of the accelerometer's mean specific force (3) and of the encoders' readings (n_arm).
    prior_information : ndarray (k, k), optional
        Inverse of the coordinates' prior covariance (none: no prior on them).
    bias_priors : (float, float), optional
        Prior variances per axis of the gyro and accelerometer biases (none: no prior).
    calibration_priors : (float, float), optional
        Prior variances of the gyro's scale-factor errors and misalignments: with them the gyro's nine
        calibration terms (:mod:`postcapture.core.triad`) are nuisance parameters too (none: known).
    """
    t_grid = np.asarray(t_grid, dtype=float)
    dt = float(t_grid[1] - t_grid[0])
    att = model.tangent_attitude
    D = np.asarray(directions, dtype=float)
    u = _Unknowns(D.shape[1], 0 if calibration_priors is None else 9)
    g = np.zeros(u.n)
    g[:u.k] = mass_gradient
    J = {name: np.zeros((u.n, u.n)) for name in ("star", "gyro", "accel", "joints")}
    W_star = np.linalg.inv(np.asarray(R_star, dtype=float))
    R_acc = np.asarray(R_accel, dtype=float)
    J_prior = _prior(u, prior_information, bias_priors, calibration_priors)
    x = np.array(x0, dtype=float)
    S = np.asarray(dx0_dp, dtype=float) @ D
    history = np.full(t_grid.size, np.nan)
    for step in range(t_grid.size - 1):
        p = model.predict(x, t_grid[step], dt, jacobians=True)
        S1 = p.F @ S + p.G @ D
        phi = rot.box_minus(model.attitude(p.x), model.attitude(x))
        G = _gyro_rows(u, phi, S[att], S1[att], dt)
        J["gyro"] += G.T @ G / sigma_gyro**2
        G = _star_rows(u, S1[att])
        J["star"] += G.T @ W_star @ G
        G = _accel_rows(u, model, phi, x, S, p.x, S1, dt)
        J["accel"] += G.T @ G / R_acc[0]
        G = _joint_rows(u, model.tangent_arm, S1)
        J["joints"] += (G.T / R_acc[3:]) @ G
        x, S = p.x, S1
        if step % 10 == 9 or step == t_grid.size - 2:
            history[step + 1] = _bound(J_prior + sum(J.values()) + 1e-30 * np.eye(u.n), g)
        if progress is not None and step % 100 == 0:
            progress((step + 1) / (t_grid.size - 1))
    return _per_sensor(u, J_prior, J, g, history)


@dataclass(frozen=True)
class _Unknowns:
    """Where each group of unknowns sits in ``theta``: ``c`` (k), gyro bias (3), accelerometer bias (3),
    initial attitude (3), gyro calibration (n_cal: 9, or 0 when it is known)."""

    k: int
    n_cal: int

    @property
    def n(self) -> int:
        return self.k + 9 + self.n_cal

    @property
    def gyro_bias(self) -> slice:
        return slice(self.k, self.k + 3)

    @property
    def accel_bias(self) -> slice:
        return slice(self.k + 3, self.k + 6)

    @property
    def attitude(self) -> slice:
        return slice(self.k + 6, self.k + 9)

    @property
    def calibration(self) -> slice:
        return slice(self.k + 9, self.k + 9 + self.n_cal)


def _prior(u: _Unknowns, prior_information, bias_priors, calibration_priors) -> np.ndarray:
    """The priors' information ``J_prior`` (n, n): zero on the unknowns without a prior."""
    J_prior = np.zeros((u.n, u.n))
    if prior_information is not None:
        J_prior[:u.k, :u.k] = prior_information
    if bias_priors is not None:
        J_prior[u.gyro_bias, u.gyro_bias] = np.eye(3) / bias_priors[0]
        J_prior[u.accel_bias, u.accel_bias] = np.eye(3) / bias_priors[1]
    if u.n_cal:
        J_prior[u.calibration, u.calibration] = np.diag([1.0 / calibration_priors[0]] * 3
                                                        + [1.0 / calibration_priors[1]] * 6)
    return J_prior


def _gyro_rows(u: _Unknowns, phi, S_att, S1_att, dt: float) -> np.ndarray:
    """Sensitivity (3, n) of the gyro's mean rate over a step of rotation ``phi``, from the attitude's
    sensitivities at its start and end."""
    G = np.zeros((3, u.n))
    G[:, :u.k] = (rot.right_jacobian_inv(phi) @ S1_att - rot.left_jacobian_inv(phi) @ S_att) / dt
    G[:, u.gyro_bias] = np.eye(3)
    if u.n_cal:
        G[:, u.calibration] = calibration_sensitivity(phi / dt)
    return G


def _star_rows(u: _Unknowns, S1_att) -> np.ndarray:
    """Sensitivity (3, n) of a star-tracker sample, from the attitude's sensitivity at its instant."""
    G = np.zeros((3, u.n))
    G[:, :u.k] = S1_att
    G[:, u.attitude] = np.eye(3)
    return G


def _accel_rows(u: _Unknowns, model, phi, x, S, x1, S1, dt: float) -> np.ndarray:
    """Sensitivity (3, n) of the accelerometer's mean specific force over a step from ``x`` to ``x1``."""
    _, Jf = mean_specific_force(phi, model.chaser_velocity(x), model.body_rate(x), model.chaser_velocity(x1),
                                model.body_rate(x1), model.accelerometer_position, dt)
    att, vel, rate = model.tangent_attitude, model.tangent_velocity, model.tangent_rate
    G = np.zeros((3, u.n))
    G[:, :u.k] = (Jf["att1"] @ S1[att] + Jf["v1"] @ S1[vel] + Jf["w1"] @ S1[rate]
                  + Jf["att0"] @ S[att] + Jf["v0"] @ S[vel] + Jf["w0"] @ S[rate])
    G[:, u.accel_bias] = np.eye(3)
    return G


def _joint_rows(u: _Unknowns, arm, S1) -> np.ndarray:
    """Sensitivity (n_arm, n) of the encoders' readings, from the arm's tangent entries ``arm``."""
    G = np.zeros((len(arm), u.n))
    G[:, :u.k] = S1[arm]
    return G


def _per_sensor(u: _Unknowns, J_prior, J: dict, g, history) -> MassCRLB:
    """The bounds from all sensors, from each alone and from the accelerations together."""
    k, n_cal = u.k, u.n_cal

    def only(keys, nuisance):
        """Bound from some sensors, with only the nuisance parameters they observe (others would make J singular)."""
        keep = [*range(k), *nuisance]
        Jk = (J_prior + sum(J[name] for name in keys))[np.ix_(keep, keep)]
        return _bound(Jk + 1e-30 * np.eye(len(keep)), g[keep])

    return MassCRLB(
        all_sensors=only(("star", "gyro", "accel", "joints"), range(k, k + 9 + n_cal)),
        star_tracker=only(("star",), range(k + 6, k + 9)),
        gyro=only(("gyro",), [*range(k, k + 3), *range(k + 9, k + 9 + n_cal)]),
        accelerometer=only(("accel",), range(k + 3, k + 6)),
        joints=only(("joints",), []),
        accelerations_only=only(("accel", "joints"), range(k + 3, k + 6)),
        history=history,
    )
