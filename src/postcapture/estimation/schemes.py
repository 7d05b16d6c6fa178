"""The recommended schemes, as compositions of steppers over recorded measurements.

- :func:`run_joint_scheme`: one :class:`~postcapture.estimation.augmented.AugmentedEKF` reads every
  sensor (gyro, star tracker, accelerometer and joint accelerations) and carries both biases.
- :func:`run_dual_scheme`: the attitude filter (a model-free :class:`~postcapture.estimation.mekf.MEKF`
  on gyro and star tracker) runs beside the parameter filter (an AugmentedEKF on the gyro and the
  accelerations, with a gyro bias of its own). The attitude solution never depends on the plant
  model, so a model error cannot corrupt it. The parameter filter does not take the MEKF's bias
  estimate: its error is common to every gyro sample, and adding its covariance to each sample's noise
  as if it were white counted the same information thousands of times (mass NEES 151 on the identical
  model with the reference profile's 0.01 rad star tracker, whose MEKF hardly learns the bias in
  300 s); estimating the bias in the parameter filter, from the plant's own rates, keeps it consistent.

In both, the measurements of one step are processed in the order gyro (the delta-angle of the step),
star tracker, accelerations, all at the step's end.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np

from postcapture.core.errors import DomainError, SimulationError
from postcapture.estimation.dual import SensorSuite, on_grid
from postcapture.estimation.filter import FilterEvent, FilterStatus, Measurement
from postcapture.estimation.history import EstimateHistory, StepFlag

__all__ = ["SchemeResult", "run_joint_scheme", "run_dual_scheme"]


@dataclass
class SchemeResult:
    """Histories of a scheme (time last) and its outcome.

    ``attitude`` is the attitude estimate with its covariance; ``mass`` and ``mass_sigma`` the total
    target mass (kg); ``params`` and ``params_sigma`` (n_p, n) the plant's parameter vector (its
    ``param_names``) and their 1-sigma; ``params_cov`` the parameters' full covariance at the end (None
    when the scheme estimates no parameter vector); ``events`` the filters' :class:`FilterEvent` lists.
    """

    attitude: EstimateHistory
    mass: np.ndarray
    mass_sigma: np.ndarray
    mass_nis: np.ndarray
    wall_s: float
    counts: dict
    params: np.ndarray | None = None
    params_sigma: np.ndarray | None = None
    param_names: tuple = ()
    events: dict = field(default_factory=dict)
    params_cov: np.ndarray | None = None


class _Recorder:
    def __init__(self, n_t: int, n_p: int, m_err: int):
        self.q = np.full((4, n_t), np.nan)
        self.P = np.full((m_err, m_err, n_t), np.nan)
        self.nis = np.full(n_t, np.nan)
        self.mass_nis = np.full(n_t, np.nan)
        self.flags = np.zeros(n_t, dtype=np.uint8)
        self.p = np.full((n_p, n_t), np.nan)
        self.ps = np.full((n_p, n_t), np.nan)
        self.mass = np.full(n_t, np.nan)
        self.mass_sigma = np.full(n_t, np.nan)

    def parameters(self, k: int, filt, panel_mass: float) -> None:
        p = filt.parameters()
        C = filt.parameter_covariance()
        self.p[:, k] = p
        self.ps[:, k] = np.sqrt(np.maximum(np.diag(C), 0.0))
        self.mass[k] = p[0] + panel_mass
        self.mass_sigma[k] = self.ps[0, k]

    def flag(self, k: int, res, missing_flag=StepFlag.MEASUREMENT_MISSING) -> None:
        if res is None:
            self.flags[k] |= missing_flag
        elif res.accepted:
            self.flags[k] |= StepFlag.UPDATED
        else:
            self.flags[k] |= StepFlag.REJECTED


def _grids(sensors: SensorSuite, t_grid):
    star = on_grid(sensors.star, t_grid)
    gyro = on_grid(sensors.gyro, t_grid)
    z = np.vstack([on_grid(sensors.accel, t_grid), on_grid(sensors.joints, t_grid)])
    return star, gyro, z


def _finish(name, rec: _Recorder, t_grid, labels, counts, events, filt, wall0):
    diverged = [e.t for evs in events.values() for e in evs if e.kind == "diverged"]
    message = "completed" if not diverged else f"diverged at t = {min(diverged):.6g} s and re-initialised"
    stopped = [e.t for e in getattr(filt, "events", ()) if e.kind == "diverged" and e.cause.startswith("stopped")]
    if stopped:
        message += f"; its plant copy failed again at t = {stopped[0]:.6g} s, where its estimates end"
    for t_d in diverged:  # marked where it happened; the filter went on
        rec.flags[min(int(np.searchsorted(t_grid, t_d)), t_grid.size - 1)] |= np.uint8(int(StepFlag.DIVERGED))
    history = EstimateHistory(
        filter_name=name, t=t_grid, q_BN=rec.q, P=rec.P, nis=rec.nis, flags=rec.flags, error_labels=labels,
        states={"mass": rec.mass[None, :], "mass_sigma": rec.mass_sigma[None, :]}, counts=counts,
        success=not diverged, status=0 if not diverged else -1, message=message,
    )
    return SchemeResult(history, rec.mass, rec.mass_sigma, rec.mass_nis, time.perf_counter() - wall0, counts,
                        rec.p, rec.ps, tuple(filt.model.param_names), events, filt.parameter_covariance())


def run_joint_scheme(filt, sensors: SensorSuite, t_grid, *, R_gyro, R_star, R_accel, panel_mass: float,
                     progress=None, name: str = "joint") -> SchemeResult:
    """Run an AugmentedEKF (with its gyro bias) through recorded sensors.

    Parameters
    ----------
    filt : AugmentedEKF
    sensors : SensorSuite
    t_grid : ndarray (n,)
        Uniform filter instants; the gyro sample at ``t_k`` is the mean rate over ``[t_k, t_k+1]``.
    R_gyro, R_star : ndarray (3, 3)
        Noise of a gyro sample (rad/s)^2 and of the star tracker (rad^2).
    R_accel : ndarray (m,)
        Variances of the accelerometer and joint-acceleration samples.
    panel_mass : float
        The target's panels' mass (kg), added to the hub's to give the total target mass.
    """
    return _run(None, filt, sensors, t_grid, R_gyro, R_star, R_accel, panel_mass, progress, name)


def run_dual_scheme(mekf, filt, sensors: SensorSuite, t_grid, *, R_gyro, R_accel, panel_mass: float,
                    progress=None, name: str = "dual") -> SchemeResult:
    """Run the MEKF beside an AugmentedEKF on the gyro and the accelerations (see the module docstring).

    Parameters are those of :func:`run_joint_scheme`; ``mekf`` is a
    :class:`~postcapture.estimation.mekf.MEKF` (gyro-driven, star-tracker corrected), whose own star-tracker
    covariance is used.
    """
    return _run(mekf, filt, sensors, t_grid, R_gyro, mekf.tuning.star_covariance, R_accel, panel_mass, progress,
                name)


def _run(mekf, filt, sensors, t_grid, R_gyro, R_star, R_accel, panel_mass, progress, name) -> SchemeResult:
    """One loop for both schemes: with ``mekf`` the attitude comes from it and ``filt`` leaves out the
    star tracker; without, ``filt`` reads the star tracker too."""
    wall0 = time.perf_counter()
    t_grid = np.asarray(t_grid, dtype=float)
    n_t, dt = t_grid.size, float(t_grid[1] - t_grid[0])
    star, gyro, z = _grids(sensors, t_grid)
    Rz = np.diag(R_accel)
    rec = _Recorder(n_t, len(filt.model.param_names), 6)
    sel = np.r_[np.arange(filt.att.start, filt.att.stop), np.arange(filt.i_bg.start, filt.i_bg.stop)]

    def record(k):
        rec.q[:, k] = filt.q_BN if mekf is None else mekf.q_BN
        rec.P[..., k] = filt.P[np.ix_(sel, sel)] if mekf is None else mekf.P
        rec.parameters(k, filt, panel_mass)

    record(0)
    last = None
    lost = False  # the plant filter failed again right after its re-initialisation: it stops, the run goes on
    for k in range(n_t - 1):
        t, t1 = t_grid[k], t_grid[k + 1]
        w = gyro[:, k]
        try:
            if mekf is None:
                if lost:
                    break
                filt.predict(t, dt)
                r = filt.update(Measurement("gyro", t1, w, R_gyro))
                rec.flag(k + 1, r, StepFlag.INPUT_MISSING)
                r = filt.update(Measurement("star_tracker", t1, star[:, k + 1], R_star))
            else:
                if np.all(np.isfinite(w)):
                    last = w
                else:
                    rec.flags[k + 1] |= StepFlag.INPUT_MISSING
                if last is not None:
                    mekf.predict(t, dt, last)
                r = mekf.update(Measurement("star_tracker", t1, star[:, k + 1], R_star))
                if not lost:
                    filt.predict(t, dt)
                    filt.update(Measurement("gyro", t1, w, R_gyro))
            rec.flag(k + 1, r)
            if r is not None and r.accepted:
                rec.nis[k + 1] = r.nis
            if not lost:
                r = filt.update(Measurement("accelerations", t1, z[:, k + 1], Rz))
                if r is not None and r.accepted:
                    rec.mass_nis[k + 1] = r.nis
        except (SimulationError, DomainError) as exc:
            lost = True  # its histories end here (NaN after); a dual's attitude filter goes on without it
            filt.status = FilterStatus.DIVERGED
            filt.events.append(FilterEvent(float(t), "diverged", f"stopped: the plant copy failed again: {exc}"))
        if lost:
            rec.q[:, k + 1] = np.nan if mekf is None else mekf.q_BN
            if mekf is not None:
                rec.P[..., k + 1] = mekf.P
        else:
            record(k + 1)
        if progress is not None and k % 50 == 0:
            progress((k + 1) / (n_t - 1))
    labels = ("dtheta_x", "dtheta_y", "dtheta_z", "dbias_x", "dbias_y", "dbias_z")
    filters = [filt] if mekf is None else [mekf, filt]
    counts = {key: sum(f.counts.get(key, 0) for f in filters) for f in filters for key in f.counts}
    events = {f.name: list(f.events) for f in filters}
    return _finish(name, rec, t_grid, labels, counts, events, filt, wall0)
