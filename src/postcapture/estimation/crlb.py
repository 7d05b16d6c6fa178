"""Cramer-Rao lower bound of the target mass for a run's excitation and sensor noise.

Along the true trajectory, the plant's sensitivity to the mass, ``S_k = dx_k / dm``, follows the exact
step Jacobians (``S_k+1 = F_k S_k + g_k``, ``S_0 = dx_0/dm``: the initial state computed from the
scenario depends on the mass). Each measurement's sensitivity to the parameters
``p = (m, gyro bias (3), accelerometer bias (3), initial attitude (3))`` follows:

- star tracker ``box_minus(q_k, q_0)``: ``dtheta_k/dm = S_k[att]``, ``d/d theta_0 = I`` (to first order);
- gyro mean rate over ``[t_k, t_k+1]``: ``(Jr^-1 S_k+1[att] - Jl^-1 S_k[att]) / dt`` and ``I`` on its bias;
- accelerometer: ``H_k S_k + h_k`` and ``I`` on its bias; joint accelerations: ``H_k S_k + h_k``.

The Fisher information ``J = sum_k G_k^T R^-1 G_k`` with each sensor's noise covariance ``R`` gives the
bound ``sqrt([J^-1]_mm)``: no unbiased estimator of the mass, knowing the plant model and the
initial state up to the listed nuisance parameters, does better on the same data. It is computed for
every sensor alone and for all together.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from postcapture.core import rotations as rot

__all__ = ["MassCRLB", "mass_crlb"]


@dataclass
class MassCRLB:
    """One-sigma bounds on the mass (kg) from each sensor and from all of them."""

    all_sensors: float
    star_tracker: float
    gyro: float
    accelerometer: float
    joints: float
    accelerations_only: float  # accelerometer and joints together: what a dual mass filter sees

    def as_dict(self) -> dict:
        """Plain dict, for JSON."""
        return dict(self.__dict__)


def _bound(J: np.ndarray) -> float:
    """``sqrt([J^-1]_00)`` with a pseudo-inverse guard for unidentifiable nuisance directions."""
    try:
        inv = np.linalg.inv(J)
    except np.linalg.LinAlgError:
        inv = np.linalg.pinv(J)
    val = inv[0, 0]
    return float(np.sqrt(val)) if val > 0 else float("inf")


def mass_crlb(model, x0, S0, t_grid, *, R_star, sigma_gyro: float, sigma_accel: float, sigma_joint: float,
              progress=None) -> MassCRLB:
    """The mass CRLB along the trajectory of ``model`` (at the true mass) from ``x0``.

    Parameters
    ----------
    model : ProcessModel
        A plant copy at the true mass.
    x0, S0 : ndarray
        Initial state and its derivative with respect to the mass (tangent).
    t_grid : ndarray (n,)
        Uniform sample instants of every sensor.
    R_star : ndarray (3, 3)
        Star-tracker covariance (rad^2).
    sigma_gyro, sigma_accel, sigma_joint : float
        One-sigma noise of a gyro sample (rad/s), accelerometer (m/s^2) and joint acceleration (rad/s^2).
    """
    t_grid = np.asarray(t_grid, dtype=float)
    dt = float(t_grid[1] - t_grid[0])
    att = model.tangent_attitude
    n_p = 10  # m, gyro bias (3), accel bias (3), initial attitude (3)
    J = {name: np.zeros((n_p, n_p)) for name in ("star", "gyro", "accel", "joints")}
    W_star = np.linalg.inv(np.asarray(R_star, dtype=float))
    x = np.array(x0, dtype=float)
    S = np.array(S0, dtype=float)
    for k in range(t_grid.size - 1):
        p = model.predict(x, t_grid[k], dt, jacobians=True)
        S1 = p.F @ S + p.g
        # gyro sample at t_k: mean rate over the step, box_minus(q_k+1, q_k) / dt
        phi = rot.box_minus(model.attitude(p.x), model.attitude(x))
        G = np.zeros((3, n_p))
        G[:, 0] = (rot.right_jacobian_inv(phi) @ S1[att] - rot.left_jacobian_inv(phi) @ S[att]) / dt
        G[:, 1:4] = np.eye(3)
        J["gyro"] += G.T @ G / sigma_gyro**2
        # star tracker at t_k+1
        G = np.zeros((3, n_p))
        G[:, 0] = S1[att]
        G[:, 7:10] = np.eye(3)
        J["star"] += G.T @ W_star @ G
        # accelerometer and joints at t_k+1
        dz = p.H @ S1 + p.h
        G = np.zeros((3, n_p))
        G[:, 0] = dz[:3]
        G[:, 4:7] = np.eye(3)
        J["accel"] += G.T @ G / sigma_accel**2
        Gj = np.zeros((dz.size - 3, n_p))
        Gj[:, 0] = dz[3:]
        J["joints"] += Gj.T @ Gj / sigma_joint**2
        x, S = p.x, S1
        if progress is not None and k % 100 == 0:
            progress((k + 1) / (t_grid.size - 1))
    def only(keys, nuisance):
        """Bound from some sensors, with only the nuisance parameters they observe (others would make J singular)."""
        Jk = sum(J[k] for k in keys)
        keep = [0, *nuisance]
        return _bound(Jk[np.ix_(keep, keep)])

    return MassCRLB(
        all_sensors=only(("star", "gyro", "accel", "joints"), range(1, 10)),
        star_tracker=only(("star",), range(7, 10)),
        gyro=only(("gyro",), range(1, 4)),
        accelerometer=only(("accel",), range(4, 7)),
        joints=only(("joints",), []),
        accelerations_only=only(("accel", "joints"), range(4, 7)),
    )
