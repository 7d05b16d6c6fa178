"""The joint (augmented-state) EKF: the whole plant state, the gyro bias and the target mass in one state.

The reference proposed it as future work. Error state (dimension ``n + 7``): the plant's tangent
``(dq, dv)``, the gyro bias ``db`` (3), the accelerometer bias ``da`` (3) and the sigmoid pre-image of
the mass ``x_m`` (1). The plant copy propagates with the exact step Jacobian ``F`` and mass
derivative ``g``; the biases are random walks and the mass a scheduled one:

    Phi = [[F, 0, 0, g dtheta/dx_m], [0, I, 0, 0], [0, 0, I, 0], [0, 0, 0, 1]].

Measurements at each step's end: star tracker (attitude error, ``H = [I_att]``), accelerometer and
joint accelerations (``H`` from the model, mass column ``h dtheta/dx_m``). The gyro sample taken at
``t_k`` is the mean rate over ``[t_k, t_k+1]`` (a delta-angle), a function of both ends of the step:
``box_minus(q_k+1, q_k) / dt + b``. It is processed against the state at ``t_k`` with
``H = (Jr^-1(phi) F_att - Jl^-1(phi) E_att) / dt`` (and ``I`` on the bias), the exact first-order
derivative of the box-minus (a plain difference would make the gyro appear to observe the absolute
attitude), before the covariance is propagated; the correction is carried through the step to first
order, ``x_k+1 <- x_k+1 (+) F dx_k``.
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np

from postcapture.core import kalman
from postcapture.core import rotations as rot
from postcapture.core.errors import CovarianceError, FilterDivergenceError
from postcapture.core.sigmoid import SigmoidMap
from postcapture.estimation.dual import DualResult, SensorSuite, on_grid
from postcapture.estimation.history import EstimateHistory, StepFlag

__all__ = ["JointTuning", "run_joint"]


@dataclass(frozen=True)
class JointTuning:
    """Noise model of the joint EKF.

    Parameters
    ----------
    R_star : ndarray (3, 3)
        Star-tracker covariance (rad^2).
    sigma_gyro : float
        One-sigma of a gyro sample (rad/s), white part.
    sigma_u : float
        Gyro bias random walk (rad/s^1.5).
    P0_accel_bias : float
        Initial accelerometer-bias variance per axis ((m/s^2)^2).
    sigma_accel_bias_walk : float
        Accelerometer bias random walk (m/s^2.5).
    R_accel : ndarray (m,)
        Variances of the accelerometer (3) and joint-acceleration (n_arm) samples.
    q_model : float
        Process-noise variance per step on every plant velocity coordinate (the model's own error).
    q_mass_start, q_mass_end : float
        Scheduled process-noise variance on the mass pre-image per step.
    P0_attitude : ndarray (3, 3)
    P0_bias : float
        Initial bias variance per axis ((rad/s)^2).
    P0_mass : float
        Initial variance of the mass pre-image.
    P0_state : float
        Initial variance of every other plant coordinate (the initial state is known up to this).
    sigmoid : SigmoidMap
    gate_probability : float or None
    """

    R_star: np.ndarray
    sigma_gyro: float
    sigma_u: float
    R_accel: np.ndarray
    P0_accel_bias: float = (50e-6 * 9.80665) ** 2
    sigma_accel_bias_walk: float = 0.0
    q_model: float = 1e-14
    q_mass_start: float = 20.1
    q_mass_end: float = 1e-4
    P0_attitude: np.ndarray | None = None
    P0_bias: float = (0.2 * np.pi / 180 / 3600) ** 2
    P0_mass: float = 100.0**2
    P0_state: float = 1e-14
    sigmoid: SigmoidMap = SigmoidMap()
    gate_probability: float | None = 0.9999


def run_joint(model, sensors: SensorSuite, tuning: JointTuning, *, x0, theta0: float, t_grid, S0=None, q0_BN=None,
              name: str = "joint", raise_on_divergence: bool = True, progress=None) -> DualResult:
    """Run the joint EKF over a time grid (same inputs and outputs as :func:`~postcapture.estimation.dual.run_dual`)."""
    wall0 = time.perf_counter()
    t_grid = np.asarray(t_grid, dtype=float)
    n_t, dt = t_grid.size, float(t_grid[1] - t_grid[0])
    n = model.n
    N = n + 7
    att, ib, ia, im = model.tangent_attitude, slice(n, n + 3), slice(n + 3, n + 6), n + 6
    smap = tuning.sigmoid
    x = np.array(x0, dtype=float)
    if q0_BN is not None:
        d = np.zeros(n)
        d[att] = rot.box_minus(np.asarray(q0_BN, dtype=float), model.attitude(x))
        x = model.retract(x, d)
    bias = np.zeros(3)
    abias = np.zeros(3)
    xm = float(smap.inverse(theta0))
    S0 = np.zeros(n) if S0 is None else np.asarray(S0, dtype=float)
    # Initial covariance: the plant's initial state follows the mass it was computed with (x0 = x0(theta)).
    P = np.zeros((N, N))
    P[:n, :n] = tuning.P0_state * np.eye(n)
    P[att, att] = tuning.P0_attitude if tuning.P0_attitude is not None else tuning.R_star * 4
    P[ib, ib] = tuning.P0_bias * np.eye(3)
    P[ia, ia] = tuning.P0_accel_bias * np.eye(3)
    J0 = np.zeros(N)
    J0[:n] = S0 * smap.derivative(xm)
    J0[im] = 1.0
    P += tuning.P0_mass * np.outer(J0, J0)  # mass error and the initial state's error it implies
    star = on_grid(sensors.star, t_grid)
    gyro = on_grid(sensors.gyro, t_grid)
    z_all = np.vstack([on_grid(sensors.accel, t_grid), on_grid(sensors.joints, t_grid)])
    R_g = (tuning.sigma_gyro**2) * np.eye(3)
    Rz = np.asarray(tuning.R_accel, dtype=float)
    Q = np.zeros((N, N))
    nv = n // 2
    Q[nv:n, nv:n] = tuning.q_model * np.eye(nv)
    Q[ib, ib] = tuning.sigma_u**2 * dt * np.eye(3)
    Q[ia, ia] = tuning.sigma_accel_bias_walk**2 * dt * np.eye(3)
    q_hist = np.full((4, n_t), np.nan)
    P_hist = np.full((6, 6, n_t), np.nan)
    theta = np.full(n_t, np.nan)
    sigma = np.full(n_t, np.nan)
    nis = np.full(n_t, np.nan)
    mass_nis = np.full(n_t, np.nan)
    ab_hist = np.full((3, n_t), np.nan)
    flags = np.zeros(n_t, dtype=np.uint8)
    counts = {"updates": 0, "rejected": 0, "measurements_missing": 0, "inputs_missing": 0, "mass_updates": 0}
    sel6 = np.r_[np.arange(att.start, att.stop), np.arange(n, n + 3)]

    def record(k):
        q_hist[:, k] = model.attitude(x)
        P_hist[..., k] = P[np.ix_(sel6, sel6)]
        theta[k] = smap.forward(xm)
        sigma[k] = abs(smap.derivative(xm)) * np.sqrt(P[im, im])
        ab_hist[:, k] = abias

    def apply(dx):
        nonlocal x, bias, abias, xm
        x = model.retract(x, dx[:n])
        bias = bias + dx[ib]
        abias = abias + dx[ia]
        xm = float(np.clip(xm + dx[im], -30.0 / smap.c, 30.0 / smap.c))

    record(0)
    success, status, message = True, 0, "completed"
    k = 0
    try:
        for k in range(n_t - 1):
            t, t1 = t_grid[k], t_grid[k + 1]
            frac = k / max(n_t - 2, 1)
            Q[im, im] = tuning.q_mass_start + frac * (tuning.q_mass_end - tuning.q_mass_start)
            model.mass = smap.forward(xm)
            p = model.predict(x, t, dt, jacobians=True)
            dth = smap.derivative(xm)
            Phi = np.eye(N)
            Phi[:n, :n] = p.F
            Phi[:n, im] = p.g * dth
            # the gyro's mean rate over [t_k, t_k+1], against the state at t_k
            w = gyro[:, k]
            if np.all(np.isfinite(w)):
                phi = rot.box_minus(model.attitude(p.x), model.attitude(x))
                Jr, Jl = rot.right_jacobian_inv(phi), rot.left_jacobian_inv(phi)
                Hg = np.zeros((3, N))
                Hg[:, :n] = Jr @ p.F[att, :] / dt
                Hg[:, att] -= Jl / dt  # with the term above, the absolute attitude cancels to O(phi^2)
                Hg[:, im] = Jr @ p.g[att] * dth / dt
                Hg[:, ib] = np.eye(3)
                innov = w - (phi / dt + bias)
                res = kalman.update(np.zeros(N), P, innov, Hg, R_g, gate_probability=tuning.gate_probability)
                if res.accepted:
                    P = res.P
                    dxk = res.x
                    apply(np.concatenate([np.zeros(n), dxk[n:]]))  # biases and mass now
                    # the plant correction at t_k, carried through the step to first order
                    p_x = model.retract(p.x, p.F @ dxk[:n] + p.g * dth * dxk[im])
                else:
                    p_x = p.x
                    counts["rejected"] += 1
            else:
                counts["inputs_missing"] += 1
                flags[k + 1] |= StepFlag.INPUT_MISSING
                p_x = p.x
            P = kalman.symmetrize(Phi @ P @ Phi.T + Q)
            z_hat = p.z + p.H @ model.local(p_x, p.x)
            x = p_x
            # star tracker
            qm = star[:, k + 1]
            if np.all(np.isfinite(qm)):
                Hs = np.zeros((3, N))
                Hs[:, att] = np.eye(3)
                res = kalman.update(np.zeros(N), P, rot.box_minus(qm, model.attitude(x)), Hs, tuning.R_star,
                                    gate_probability=tuning.gate_probability)
                if res.accepted:
                    d = res.x
                    z_hat = z_hat + p.H @ d[:n] + p.h * dth * d[im]
                    apply(d)
                    P = res.P
                    counts["updates"] += 1
                    flags[k + 1] |= StepFlag.UPDATED
                    nis[k + 1] = res.nis
                else:
                    counts["rejected"] += 1
                    flags[k + 1] |= StepFlag.REJECTED
            else:
                counts["measurements_missing"] += 1
                flags[k + 1] |= StepFlag.MEASUREMENT_MISSING
            # accelerometer and joint accelerations
            zm = z_all[:, k + 1]
            ok = np.isfinite(zm)
            if ok.any():
                Hz = np.zeros((zm.size, N))
                Hz[:, :n] = p.H
                Hz[:, im] = p.h * smap.derivative(xm)
                Hz[:3, ia] = np.eye(3)  # the accelerometer reads its bias too
                z_pred = z_hat.copy()
                z_pred[:3] += abias
                res = kalman.update(np.zeros(N), P, (zm - z_pred)[ok], Hz[ok], np.diag(Rz[ok]),
                                    gate_probability=tuning.gate_probability)
                if res.accepted:
                    apply(res.x)
                    P = res.P
                    counts["mass_updates"] += 1
                    mass_nis[k + 1] = res.nis
            if not (np.all(np.isfinite(P)) and np.all(np.isfinite(x))):
                raise FilterDivergenceError(name, t1, "non-finite state or covariance")
            record(k + 1)
            if progress is not None and k % 50 == 0:
                progress((k + 1) / (n_t - 1))
    except (FilterDivergenceError, CovarianceError) as exc:
        if raise_on_divergence:
            if isinstance(exc, FilterDivergenceError):
                raise
            raise FilterDivergenceError(name, t_grid[min(k + 1, n_t - 1)], str(exc)) from exc
        success, status, message = False, -1, str(exc)
        flags[k + 1 :] |= np.uint8(int(StepFlag.DIVERGED))
    history = EstimateHistory(
        filter_name=name, t=t_grid, q_BN=q_hist, P=P_hist, nis=nis, flags=flags,
        error_labels=("dtheta_x", "dtheta_y", "dtheta_z", "dbias_x", "dbias_y", "dbias_z"),
        states={"mass": theta[None, :], "mass_sigma": sigma[None, :], "accel_bias_B": ab_hist}, counts=counts,
        success=success, status=status, message=message,
    )
    return DualResult(history, theta, sigma, mass_nis, time.perf_counter() - wall0, counts)
