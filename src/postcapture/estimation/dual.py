"""The dual scheme: an attitude filter and the mass filter in parallel around one plant copy.

Each filter step from ``t_k`` to ``t_k+1``:

1. the mass filter predicts (scheduled process noise) and its estimate is routed into the plant copy;
2. the plant copy advances with its exact step Jacobian ``F`` and mass derivative ``g``;
   the state's sensitivity to the mass follows, ``S <- F S + g``;
3. the attitude filter corrects the plant copy's attitude: the model-based EKF with the star tracker
   (the copy is its process model), or the gyro-driven MEKF whose attitude and bias-corrected rate
   then overwrite the copy's (the overwritten components no longer depend on the mass: ``S = 0``);
4. the mass filter corrects with the accelerometer's mean specific force over the step and the
   encoders' angles at its end (:mod:`.increments`) against those the plant copy predicts from its state
   at the step's start and its corrected state at the end, using ``dz/dtheta`` (total: through the state
   sensitivities at both ends; partial: at a fixed state at the step's start, through the step alone);
5. with ``shift_state`` the plant copy moves to first order onto the trajectory of the new mass,
   ``x <- x (+) S d(theta)``: the copy then behaves as if it had run with the new mass all along.

With ``mass_aware_q`` the EKF also knows what the mass uncertainty does to its attitude: the copy's
remaining rate error is about ``S_rate (theta_hat - theta)``, so each step adds
``sigma_theta^2 (S_rate dt)(S_rate dt)^T`` to ``Q`` (the mass treated as a consider parameter). A
constant ``Q`` is either too small while the mass is uncertain or too large once it has converged.

Steps 1-4 are the reference's scheme (its figure 3); 5, the total sensitivity and the mass-aware ``Q``
are ours.

The filters' arithmetic and the equations between them and the plant copy (``S <- F S + g``, the lean of
``S`` on the star tracker, the mass-aware ``Q``, the devices' prediction and its derivative) are the compiled
engine's (``pc_refdual.c``), which the estimator FMU of ``ekf_flexible`` and ``mekf_flexible``
(``fmi/csrc/pc_est_refdual.c``) runs too; this module orders them around any process model.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np

from postcapture.core import rotations as rot
from postcapture.core.errors import FilterDivergenceError
from postcapture.dynamics import engine as _engine
from postcapture.estimation.attitude_ekf import AttitudeEKF, AttitudeEKFTuning
from postcapture.estimation.filter import Measurement
from postcapture.estimation.history import EstimateHistory, StepFlag
from postcapture.estimation.mass_filter import MassFilter, MassFilterTuning
from postcapture.estimation.mekf import MEKF, MEKFTuning

__all__ = ["SensorSuite", "DualConfig", "DualResult", "on_grid", "run_dual", "device_prediction"]


@dataclass
class SensorSuite:
    """Sensor records (anything with ``t``, ``values``, ``valid``): star tracker, gyro, accelerometer, joints."""

    star: object
    gyro: object
    accel: object
    joints: object


def on_grid(record, t_grid: np.ndarray) -> np.ndarray:
    """A record's values placed on a filter time grid, NaN where it has no valid sample, shape (m, n)."""
    t_grid = np.asarray(t_grid, dtype=float)
    dt = t_grid[1] - t_grid[0]
    values = np.asarray(record.values, dtype=float)
    out = np.full((values.shape[0], t_grid.size), np.nan)
    idx = np.rint((np.asarray(record.t) - t_grid[0]) / dt).astype(int)
    on = (idx >= 0) & (idx < t_grid.size) & (np.abs(t_grid[np.clip(idx, 0, t_grid.size - 1)] - record.t) < 1e-6 * dt)
    keep = on & np.asarray(record.valid, dtype=bool)
    out[:, idx[keep]] = values[:, keep]
    return out


@dataclass(frozen=True)
class DualConfig:
    """What runs in the dual scheme.

    Parameters
    ----------
    attitude : {"ekf", "mekf"}
    mass : MassFilterTuning
    ekf : AttitudeEKFTuning, optional
        Tuning of the model-based EKF (reference tuning by default).
    mekf : MEKFTuning, optional
        Tuning of the MEKF (required with ``attitude="mekf"``).
    mekf_P0 : ndarray (6, 6), optional
    shift_state : bool
        Move the plant copy along ``S d(theta)`` after each mass update (step 5).
    reset_rates : bool
        With the MEKF, overwrite the plant copy's body rate with the bias-corrected gyro rate.
    mass_aware_q : bool
        Add the mass uncertainty's effect on the plant copy's attitude to the EKF's ``Q``.
    name : str
    """

    attitude: str
    mass: MassFilterTuning
    ekf: AttitudeEKFTuning = field(default_factory=AttitudeEKFTuning.reference)
    mekf: MEKFTuning | None = None
    mekf_P0: np.ndarray | None = None
    shift_state: bool = True
    reset_rates: bool = False
    mass_aware_q: bool = False
    name: str = "dual"

    def __post_init__(self):
        if self.attitude not in ("ekf", "mekf"):
            raise ValueError(f"attitude: expected 'ekf' or 'mekf', found {self.attitude!r}")
        if self.attitude == "mekf" and self.mekf is None:
            raise ValueError("mekf: a MEKFTuning is required with attitude='mekf'")


@dataclass
class DualResult:
    """Histories of a dual run (time last) and its outcome."""

    attitude: EstimateHistory
    mass: np.ndarray  # (n,) kg
    mass_sigma: np.ndarray  # (n,) kg
    mass_nis: np.ndarray  # (n,)
    wall_s: float
    counts: dict


def device_prediction(model, x0, x1, dt: float, S0, S1):
    """The accelerometer's mean specific force over a step and the encoders' angles at its end, predicted from
    the plant states ``x0`` and ``x1`` at its two ends, and their derivatives along the state sensitivities
    ``S0`` and ``S1`` (tangent, (n,)) at those ends: ``(z (3 + n_arm), dz (3 + n_arm))`` (the engine's
    ``pc_rdual_devices``)."""
    att, vel, rate, arm = model.tangent_attitude, model.tangent_velocity, model.tangent_rate, model.tangent_arm
    S0, S1 = np.asarray(S0, dtype=float), np.asarray(S1, dtype=float)
    s0 = np.concatenate([S0[att], S0[vel], S0[rate]])
    s1 = np.concatenate([S1[att], S1[vel], S1[rate]])
    angles = np.ascontiguousarray(model.arm_angles(x1), dtype=float)
    n = 3 + angles.size
    z, dz = np.zeros(n), np.zeros(n)
    v = lambda a: np.ascontiguousarray(a, dtype=float)  # noqa: E731
    _engine.engine().rdual_devices(v(model.attitude(x0)), v(model.attitude(x1)), v(model.chaser_velocity(x0)),
                                   v(model.body_rate(x0)), v(model.chaser_velocity(x1)), v(model.body_rate(x1)),
                                   v(model.accelerometer_position), float(dt), s0, s1, angles.size, angles,
                                   v(S1[arm]), z, dz)
    return z, dz


def _propagate(F, g, S) -> np.ndarray:
    """``F S + g``: the plant state's sensitivity to the mass over one step (the engine's)."""
    out = np.zeros(S.size)
    _engine.engine().rdual_propagate(S.size, np.ascontiguousarray(F, dtype=float), np.ascontiguousarray(g, dtype=float),
                                     np.ascontiguousarray(S, dtype=float), out)
    return out


def _lean(K, s_att) -> np.ndarray:
    """``(I - K) s``: the attitude's mass sensitivity after an accepted star-tracker update of gain ``K`` (the
    engine's)."""
    out = np.array(s_att, dtype=float)
    _engine.engine().rdual_lean(np.ascontiguousarray(K, dtype=float), out)
    return out


def _mass_noise(s_rate, dt: float, sigma: float) -> np.ndarray:
    """``d d^T`` with ``d = s_rate dt sigma``: what the mass uncertainty does to the plant copy's attitude over a
    step, as process noise (the engine's)."""
    Q = np.zeros((3, 3))
    _engine.engine().rdual_mass_noise(np.ascontiguousarray(s_rate, dtype=float), float(dt), float(sigma), Q)
    return Q


def run_dual(model, sensors: SensorSuite, config: DualConfig, *, x0, theta0: float, t_grid, S0=None,
             q0_BN=None, raise_on_divergence: bool = True, progress=None) -> DualResult:
    """Run the dual scheme over a time grid.

    Parameters
    ----------
    model : ProcessModel
        The plant model; the scheme works on its own copy (``model.copy()``), whose mass the mass filter
        drives: the caller's model is never changed.
    sensors : SensorSuite
        Measurements; a sample at ``t_k+1`` corrects the step ending there; gyro samples at ``t_k`` drive
        the MEKF over ``[t_k, t_k+1]``.
    config : DualConfig
    x0 : ndarray (nx,)
        Initial plant state of the filter.
    theta0 : float
        Initial mass estimate (kg).
    t_grid : ndarray (n,)
        Filter instants (uniform).
    S0 : ndarray (n_tangent,), optional
        Initial sensitivity of the plant state to the mass (zero by default).
    q0_BN : ndarray (4,), optional
        Initial attitude estimate; overrides the attitude in ``x0``.
    raise_on_divergence : bool
        Raise :class:`FilterDivergenceError` after the run if a filter diverged (it re-initialised and
        went on); otherwise the result carries ``success=False`` and the message.
    progress : callable(fraction), optional
    """
    wall0 = time.perf_counter()
    model = model.copy()
    t_grid = np.asarray(t_grid, dtype=float)
    n_t = t_grid.size
    dt = float(t_grid[1] - t_grid[0])
    x = _start_state(model, x0, q0_BN)
    S = np.zeros(model.n) if S0 is None else np.array(S0, dtype=float)
    run = _DualRun(model, sensors, config, x, S, theta0, t_grid, dt)
    for k in range(n_t - 1):
        run.step(k)
        if progress is not None and k % 50 == 0:
            progress((k + 1) / (n_t - 1))
    history, counts = run.finish(raise_on_divergence)
    return DualResult(history, run.theta, run.sigma, run.mass_nis, time.perf_counter() - wall0, counts)


def _start_state(model, x0, q0_BN) -> np.ndarray:
    """The plant copy's initial state: ``x0``, its attitude replaced by ``q0_BN`` when given."""
    x = np.array(x0, dtype=float)
    if q0_BN is not None:
        dx = np.zeros(model.n)
        dx[model.tangent_attitude] = rot.box_minus(np.asarray(q0_BN, dtype=float), model.attitude(x))
        x = model.retract(x, dx)
    return x


def _attitude_filter(model, config: DualConfig, x, t0: float):
    """The attitude filter beside the plant copy, the star tracker's covariance it uses and the size of the
    error state it reports (3: attitude; 6: attitude and gyro bias)."""
    if config.attitude == "ekf":
        return AttitudeEKF(model, config.ekf, x, name=f"{config.name}/ekf"), config.ekf.R, 3
    P0 = config.mekf_P0 if config.mekf_P0 is not None else np.diag([1e-4] * 3 + [1e-10] * 3)
    return MEKF(config.mekf, model.attitude(x), P0, t0=t0), config.mekf.star_covariance, 6


class _DualRun:
    """The dual scheme between two filter steps: the plant copy's state ``x`` and mass sensitivity ``S``,
    both filters, the sensor records on the grid, and the histories (time last)."""

    def __init__(self, model, sensors: SensorSuite, config: DualConfig, x, S, theta0: float, t_grid, dt: float):
        self.model, self.config, self.t_grid, self.dt = model, config, t_grid, dt
        self.att, self.rate = model.tangent_attitude, model.tangent_rate
        self.x, self.S = x, S
        self.star = on_grid(sensors.star, t_grid)
        self.gyro = on_grid(sensors.gyro, t_grid)
        self.accel = on_grid(sensors.accel, t_grid)  # sample k: the increment over [t_k, t_k+1]
        self.angles = on_grid(sensors.joints, t_grid)
        self.R_z = np.diag(config.mass.R_diag)
        self.mass = MassFilter(config.mass, theta0, t_grid[0], t_grid[-1], name=f"{config.name}/mass")
        self.filt, self.R_star, self.m_err = _attitude_filter(model, config, x, t_grid[0])
        n_t = t_grid.size
        self.q_hist = np.full((4, n_t), np.nan)
        self.P_hist = np.full((self.m_err, self.m_err, n_t), np.nan)
        self.nis = np.full(n_t, np.nan)
        self.flags = np.zeros(n_t, dtype=np.uint8)
        self.theta = np.full(n_t, np.nan)
        self.sigma = np.full(n_t, np.nan)
        self.mass_nis = np.full(n_t, np.nan)
        self.inputs_missing = 0
        self._record(0)
        self.last_gyro = None

    def step(self, k: int) -> None:
        """One filter step from ``t_k`` to ``t_k+1`` (steps 1-5 of the module docstring)."""
        t, t1 = self.t_grid[k], self.t_grid[k + 1]
        x_start, S_start = self.x.copy(), self.S.copy()
        self.mass.predict(t, self.dt)
        self.model.mass = self.mass.theta
        if self.config.attitude == "ekf":
            p, S_pred, res = self._attitude_ekf(k, t, t1)
        else:
            p, S_pred, res = self._attitude_mekf(k, t, t1)
        self._flag_star(k + 1, res)
        self._correct_mass(k, t1, p, x_start, S_start, S_pred)
        self._record(k + 1)

    def _attitude_ekf(self, k: int, t: float, t1: float):
        """Steps 2-3 with the model-based EKF, whose process model is the plant copy:
        ``(prediction, S before the correction, update result)``."""
        filt, S = self.filt, self.S
        if self.config.mass_aware_q:
            filt.extra_process_noise = _mass_noise(S[self.rate], self.dt, self.mass.sigma)
        filt.predict(t, self.dt)
        p = filt.last_prediction
        S = _propagate(p.F, p.g, S)
        S_pred = S.copy()
        res = filt.update(Measurement("star_tracker", t1, self.star[:, k + 1], self.R_star))
        if res is not None and res.accepted:  # the copy's attitude now leans on the measurement
            S[self.att] = _lean(filt.last_gain, S[self.att])
        self.x, self.S = filt.x, S
        return p, S_pred, res

    def _attitude_mekf(self, k: int, t: float, t1: float):
        """Steps 2-3 with the gyro-driven MEKF, whose attitude (and with ``reset_rates`` bias-corrected rate)
        overwrite the plant copy's: ``(prediction, S before the overwrite, update result)``."""
        model, filt, att, rate = self.model, self.filt, self.att, self.rate
        p = model.predict(self.x, t, self.dt, jacobians=True)
        S = _propagate(p.F, p.g, self.S)
        S_pred = S.copy()
        self._hold_gyro(k)
        if self.last_gyro is not None:
            filt.predict(t, self.dt, self.last_gyro)
        res = filt.update(Measurement("star_tracker", t1, self.star[:, k + 1], self.R_star))
        dx = np.zeros(model.n)
        dx[att] = rot.box_minus(filt.q_BN, model.attitude(p.x))
        S[att] = 0.0
        w_next = self.gyro[:, k + 1]
        if self.config.reset_rates and np.all(np.isfinite(w_next)):
            dx[rate] = (w_next - filt.bias_B) - model.body_rate(p.x)
            S[rate] = 0.0
        self.x, self.S = model.retract(p.x, dx), S
        return p, S_pred, res

    def _hold_gyro(self, k: int) -> None:
        """Take the gyro sample at ``t_k``, or keep the last one when it is missing (counted and flagged)."""
        w = self.gyro[:, k]
        if np.all(np.isfinite(w)):
            self.last_gyro = w
        else:
            self.inputs_missing += 1
            self.flags[k + 1] |= StepFlag.INPUT_MISSING

    def _flag_star(self, i: int, res) -> None:
        """Flag what the star-tracker sample at instant ``i`` did, and keep its NIS when it was used."""
        if res is None:
            self.flags[i] |= StepFlag.MEASUREMENT_MISSING
        elif not res.accepted:
            self.flags[i] |= StepFlag.REJECTED
        else:
            self.flags[i] |= StepFlag.UPDATED
            self.nis[i] = res.nis

    def _correct_mass(self, k: int, t1: float, p, x_start, S_start, S_pred) -> None:
        """Steps 4-5: correct the mass with the step's increments and the encoders, then (``shift_state``)
        move the plant copy onto the new mass's trajectory."""
        model, mass, config = self.model, self.mass, self.config
        # the step's increments and the encoders, predicted by the plant copy's own step from its corrected state at
        # the start: the rotation over the step is the model's, not the difference of two attitude corrections (with
        # the reference's 0.01 rad star tracker those jumps alone move the mean specific force by about its noise),
        # and, in free space, neither depends on the absolute attitude, so the mass filter does not depend on which
        # attitude filter runs beside it
        if config.mass.sensitivity == "total":
            z_hat, dz = device_prediction(model, x_start, p.x, self.dt, S_start, S_pred)
        else:  # at a fixed state at the step's start: the mass acts through this step alone
            z_hat, dz = device_prediction(model, x_start, p.x, self.dt, np.zeros(model.n), p.g)
        theta_before = mass.theta
        z_meas = np.concatenate([self.accel[:, k], self.angles[:, k + 1]])
        mres = mass.update(Measurement("accelerations", t1, z_meas - z_hat, self.R_z, H=dz))
        if mres is not None and mres.accepted:
            self.mass_nis[k + 1] = mres.nis
            if config.shift_state and config.mass.sensitivity == "total":
                self.x = model.retract(self.x, self.S * (mass.theta - theta_before))
                if config.attitude == "ekf":
                    self.filt.x = self.x

    def _record(self, i: int) -> None:
        """Record the estimates at instant ``i``."""
        self.q_hist[:, i] = self.model.attitude(self.x) if self.config.attitude == "ekf" else self.filt.q_BN
        self.P_hist[..., i] = self.filt.P[:self.m_err, :self.m_err]
        self.theta[i], self.sigma[i] = self.mass.theta, self.mass.sigma

    def finish(self, raise_on_divergence: bool):
        """The run's attitude history and counts; a divergence raises, or flags ``DIVERGED`` from there on."""
        filt, mass = self.filt, self.mass
        events = list(filt.events) + list(mass.events)
        success, status, message = self._outcome(events, raise_on_divergence)
        counts = {key: filt.counts.get(key, 0) for key in ("updates", "rejected", "measurements_missing", "recoveries",
                                                            "divergences")}
        counts["inputs_missing"] = self.inputs_missing
        counts["mass_updates"] = mass.counts["updates"]
        counts["recoveries"] += mass.counts["recoveries"]
        counts["divergences"] += mass.counts["divergences"]
        history = EstimateHistory(
            filter_name=self.config.name,
            t=self.t_grid,
            q_BN=self.q_hist,
            P=self.P_hist,
            nis=self.nis,
            flags=self.flags,
            error_labels=("dtheta_x", "dtheta_y", "dtheta_z")
            + (("dbias_x", "dbias_y", "dbias_z") if self.m_err == 6 else ()),
            states={"mass": self.theta[None, :], "mass_sigma": self.sigma[None, :]},
            counts=counts,
            success=success,
            status=status,
            message=message,
            events=tuple(sorted(events, key=lambda e: e.t)),
        )
        return history, counts

    def _outcome(self, events: list, raise_on_divergence: bool):
        """``(success, status, message)``: the first divergence of either filter raises or flags the rest."""
        diverged = sorted((e for e in events if e.kind == "diverged"), key=lambda e: e.t)
        if not diverged:
            return True, 0, "completed"
        first = diverged[0]
        who = self.filt.name if first in self.filt.events else self.mass.name
        if raise_on_divergence:
            raise FilterDivergenceError(who, first.t, first.cause)
        self.flags[int(np.searchsorted(self.t_grid, first.t)) :] |= np.uint8(int(StepFlag.DIVERGED))
        return False, -1, f"filter {who!r} diverged at t = {first.t:.6g} s: {first.cause} (re-initialised, went on)"
