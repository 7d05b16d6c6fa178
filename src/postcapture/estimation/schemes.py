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

In both, the measurements of one step are processed in the order gyro (the mean rate over the step),
star tracker, accelerometer (the mean specific force over the step), encoders (the joint angles at the
step's end). ``R`` gives each sensor's noise covariance as the filters assume it, by measurement kind.
"""

from __future__ import annotations

import logging
import math
import time
from dataclasses import dataclass, field

import numpy as np

from postcapture.core.errors import DomainError, SimulationError
from postcapture.core.units import DEG_PER_HOUR
from postcapture.estimation.detect import DetectionPolicy
from postcapture.estimation.dual import SensorSuite, on_grid
from postcapture.estimation.filter import FilterEvent, FilterStatus, Measurement
from postcapture.estimation.history import EstimateHistory, StepFlag
from postcapture.estimation.supervisor import Supervisor

__all__ = ["SchemeResult", "run_joint_scheme", "run_dual_scheme"]

logger = logging.getLogger(__name__)


@dataclass
class SchemeResult:
    """Histories of a scheme (time last) and its outcome.

    ``attitude`` is the attitude estimate with its covariance; ``mass`` and ``mass_sigma`` the total
    target mass (kg); ``params`` and ``params_sigma`` (n_p, n) the plant's parameter vector (its
    ``param_names``) and their 1-sigma; ``params_cov`` the parameters' full covariance at the end (None
    when the scheme estimates no parameter vector); ``events`` the filters' :class:`FilterEvent` lists;
    ``nis`` the NIS of every accepted update by measurement kind (n,), NaN where there was none, and
    ``mass_nis`` that of the accelerometer and encoder updates together; ``detections`` the sensor faults
    found and handled (:class:`~postcapture.estimation.supervisor.Detection`) and ``validity`` the
    ``(time, text)`` of every sensor found model inconsistent.
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
    nis: dict = field(default_factory=dict)
    detections: list = field(default_factory=list)
    validity: list = field(default_factory=list)


# the step flags as plain ints: an enum member's lookup costs microseconds (Python 3.11), thousands of times a run
_UPDATED, _REJECTED = int(StepFlag.UPDATED), int(StepFlag.REJECTED)
_MISSING, _INPUT_MISSING = int(StepFlag.MEASUREMENT_MISSING), int(StepFlag.INPUT_MISSING)


class _Recorder:
    def __init__(self, n_t: int, n_p: int, m_err: int):
        self.q = np.full((4, n_t), np.nan)
        self.P = np.full((m_err, m_err, n_t), np.nan)
        self.nis_att = np.full(n_t, np.nan)
        self.flags = np.zeros(n_t, dtype=np.uint8)
        self.p = np.full((n_p, n_t), np.nan)
        self.ps = np.full((n_p, n_t), np.nan)
        self.mass = np.full(n_t, np.nan)
        self.mass_sigma = np.full(n_t, np.nan)
        self.by_kind = {kind: np.full(n_t, np.nan) for kind in KINDS}

    def nis_attitude(self, k: int, value: float) -> None:
        self.nis_att[k] = value

    def parameters(self, k: int, filt, panel_mass: float) -> None:
        both = getattr(filt, "parameters_with_covariance", None)  # one engine call (a reference filter has two)
        p, C = both() if both is not None else (filt.parameters(), filt.parameter_covariance())
        self.p[:, k] = p
        self.ps[:, k] = np.sqrt(np.maximum(np.diag(C), 0.0))
        self.mass[k] = p[0] + panel_mass
        self.mass_sigma[k] = self.ps[0, k]

    def flag(self, k: int, res, missing_flag=_MISSING) -> None:
        if res is None:
            self.flags[k] |= missing_flag
        elif res.accepted:
            self.flags[k] |= _UPDATED
        else:
            self.flags[k] |= _REJECTED

    def nis(self, k: int, kind: str, res) -> None:
        if res is not None and res.accepted:
            self.by_kind[kind][k] = res.nis


KINDS = ("gyro", "star_tracker", "accelerometer", "encoders")
"""Measurement kinds of the recommended schemes, in the order a step processes them."""

_XYZ = (0, 1, 2)  # the channels of a star-tracker or gyro update: it uses all three or is missing


def _grids(sensors: SensorSuite, t_grid) -> dict:
    return {"gyro": on_grid(sensors.gyro, t_grid), "star_tracker": on_grid(sensors.star, t_grid),
            "accelerometer": on_grid(sensors.accel, t_grid), "encoders": on_grid(sensors.joints, t_grid)}


def _finish(name, rec: _Recorder, t_grid, labels, counts, events, filt, wall0):
    diverged = [e.t for evs in events.values() for e in evs if e.kind == "diverged"]
    message = "completed" if not diverged else f"diverged at t = {min(diverged):.6g} s and re-initialised"
    stopped = [e.t for e in getattr(filt, "events", ()) if e.kind == "diverged" and e.cause.startswith("stopped")]
    if stopped:
        message += f"; its plant copy failed again at t = {stopped[0]:.6g} s, where its estimates end"
    for t_d in diverged:  # marked where it happened; the filter went on
        rec.flags[min(int(np.searchsorted(t_grid, t_d)), t_grid.size - 1)] |= np.uint8(int(StepFlag.DIVERGED))
    history = EstimateHistory(
        filter_name=name, t=t_grid, q_BN=rec.q, P=rec.P, nis=rec.nis_att, flags=rec.flags, error_labels=labels,
        states={"mass": rec.mass[None, :], "mass_sigma": rec.mass_sigma[None, :]}, counts=counts,
        success=not diverged, status=0 if not diverged else -1, message=message,
    )
    mass_nis = np.where(np.isfinite(rec.by_kind["accelerometer"]) | np.isfinite(rec.by_kind["encoders"]),
                        np.nan_to_num(rec.by_kind["accelerometer"]) + np.nan_to_num(rec.by_kind["encoders"]), np.nan)
    return SchemeResult(history, rec.mass, rec.mass_sigma, mass_nis, time.perf_counter() - wall0, counts,
                        rec.p, rec.ps, tuple(filt.model.param_names), events, filt.parameter_covariance(),
                        dict(rec.by_kind))


def run_joint_scheme(filt, sensors: SensorSuite, t_grid, *, R: dict, panel_mass: float, progress=None,
                     name: str = "joint", detection: DetectionPolicy | None = DetectionPolicy()) -> SchemeResult:
    """Run an AugmentedEKF (with its gyro bias) through recorded sensors.

    Parameters
    ----------
    filt : AugmentedEKF
    sensors : SensorSuite
    t_grid : ndarray (n,)
        Uniform filter instants; the gyro and accelerometer samples at ``t_k`` are their increments over
        ``[t_k, t_k+1]``.
    R : dict of str to ndarray
        Noise covariance of one sample by kind (:data:`KINDS`): ``gyro`` (3, 3) (rad/s)^2,
        ``star_tracker`` (3, 3) rad^2, ``accelerometer`` (3, 3) (m/s^2)^2, ``encoders`` (n_arm, n_arm) rad^2.
    panel_mass : float
        The target's panels' mass (kg), added to the hub's to give the total target mass.
    detection : DetectionPolicy or None
        How sensor faults are detected and handled (:mod:`.supervisor`); None: not supervised.
    """
    return _Run(None, filt, sensors, t_grid, R, detection).run(panel_mass, progress, name)


def run_dual_scheme(mekf, filt, sensors: SensorSuite, t_grid, *, R: dict, panel_mass: float, progress=None,
                    name: str = "dual", detection: DetectionPolicy | None = DetectionPolicy()) -> SchemeResult:
    """Run the MEKF beside an AugmentedEKF on the gyro, the accelerometer and the encoders (see the module
    docstring).

    Parameters are those of :func:`run_joint_scheme`; ``mekf`` is a
    :class:`~postcapture.estimation.mekf.MEKF` (gyro-driven, star-tracker corrected), whose own star-tracker
    covariance is used.
    """
    R = {**R, "star_tracker": mekf.tuning.star_covariance}
    return _Run(mekf, filt, sensors, t_grid, R, detection).run(panel_mass, progress, name)


class _Run:
    """One loop for both schemes: with ``mekf`` the attitude comes from it and ``filt`` leaves out the
    star tracker; without, ``filt`` reads the star tracker too."""

    def __init__(self, mekf, filt, sensors, t_grid, R, detection):
        self.mekf, self.filt, self.R = mekf, filt, R
        self.t_grid = np.asarray(t_grid, dtype=float)
        self.dt = float(self.t_grid[1] - self.t_grid[0])
        self.grids = _grids(sensors, self.t_grid)
        ok = np.all(np.isfinite(self.grids["gyro"]), axis=0)
        self.last_gyro = np.maximum.accumulate(np.where(ok, np.arange(ok.size), -1))  # for the MEKF's input
        sigmas = {kind: np.sqrt(np.diag(R[kind])) for kind in KINDS}
        # a re-opened bias is given at least its own prior (the turn-on uncertainty the filters started with)
        floor = {"gyro": max(DEG_PER_HOUR, float(np.sqrt(filt.tuning.P0_gyro_bias))),
                 "accelerometer": float(np.sqrt(filt.tuning.P0_accel_bias))}
        self.sup = None if detection is None else Supervisor(
            detection, self.dt, sigmas, {"attitude": mekf, "plant": filt}, bias_floor=floor)

    def _value(self, kind: str, k: int) -> np.ndarray:
        v = self.grids[kind][:, k]
        return v if self.sup is None else self.sup.mask(kind, v)

    def _update(self, f, kind: str, t1: float, k: int, rec, kk: int):
        value = self._value(kind, k)
        res = f.update(Measurement(kind, t1, value, self.R[kind]))
        if rec is not None:
            rec.nis(kk, kind, res)
        channels = _XYZ if kind in ("star_tracker", "gyro") else [i for i, v in enumerate(value.tolist())
                                                                  if math.isfinite(v)]
        return kind, res, channels

    def step(self, k: int, rec=None) -> list:
        """Filter cycle ``k`` (``t_k`` to ``t_k+1``); returns ``(kind, result, channels)`` of its updates."""
        mekf, filt, t, t1, dt = self.mekf, self.filt, self.t_grid[k], self.t_grid[k + 1], self.dt
        out = []
        if mekf is None:
            filt.predict(t, dt)
            out.append(self._update(filt, "gyro", t1, k, rec, k + 1))
            if rec is not None:
                rec.flag(k + 1, out[-1][1], _INPUT_MISSING)
            out.append(self._update(filt, "star_tracker", t1, k + 1, rec, k + 1))
        else:
            j = self.last_gyro[k]
            if rec is not None and j != k:
                rec.flags[k + 1] |= _INPUT_MISSING
            if j >= 0:
                mekf.predict(t, dt, self.grids["gyro"][:, j])
            out.append(self._update(mekf, "star_tracker", t1, k + 1, rec, k + 1))
            filt.predict(t, dt)
            out.append(self._update(filt, "gyro", t1, k, rec, k + 1))
        r = next(res for kind, res, _ in out if kind == "star_tracker")
        if rec is not None:
            rec.flag(k + 1, r)
            if r is not None and r.accepted:
                rec.nis_attitude(k + 1, r.nis)
        # the accelerometer's sample at t_k is its increment over [t_k, t_k+1]; the encoders' at t_k+1 their angles
        out.append(self._update(filt, "accelerometer", t1, k, rec, k + 1))
        out.append(self._update(filt, "encoders", t1, k + 1, rec, k + 1))
        return out

    def _supervise(self, k: int, updates) -> None:
        """Feed the detectors; on an alarm, re-process from its onset to the end of cycle ``k``."""
        t1 = self.t_grid[k + 1]
        alarms = [a for kind, res, channels in updates for a in self.sup.observe(t1, kind, res, channels)]
        if not alarms:
            return
        kind, alarm = min(alarms, key=lambda ka: ka[1].onset)
        k0 = self.sup.handle(kind, alarm, self.t_grid)
        logger.warning("%s", self.sup.detections[-1].describe())
        for j in range(k0, k + 1):
            self.sup.before_step(j)
            self.step(j)

    def run(self, panel_mass: float, progress, name: str) -> SchemeResult:
        wall0 = time.perf_counter()
        mekf, filt, n_t = self.mekf, self.filt, self.t_grid.size
        rec = _Recorder(n_t, len(filt.model.param_names), 6)
        sel = np.r_[np.arange(filt.att.start, filt.att.stop), np.arange(filt.i_bg.start, filt.i_bg.stop)]
        block = np.ix_(sel, sel)

        def record(k):
            rec.q[:, k] = filt.q_BN if mekf is None else mekf.q_BN
            rec.P[..., k] = filt.P[block] if mekf is None else mekf.P[:6, :6]
            rec.parameters(k, filt, panel_mass)

        record(0)
        if self.sup is not None:
            self.sup.save(0)
        lost = False  # the plant filter failed again right after its re-initialisation: it stops, the run goes on
        for k in range(n_t - 1):
            if lost:
                if mekf is None:
                    break
                self._attitude_only(k, rec)
                continue
            try:
                updates = self.step(k, rec)
                if self.sup is not None:
                    self._supervise(k, updates)
            except (SimulationError, DomainError) as exc:
                lost = True  # its histories end here (NaN after); a dual's attitude filter goes on without it
                filt.status = FilterStatus.DIVERGED
                filt.events.append(FilterEvent(float(self.t_grid[k]), "diverged",
                                               f"stopped: the plant copy failed again: {exc}"))
                if mekf is not None:
                    rec.q[:, k + 1], rec.P[..., k + 1] = mekf.q_BN, mekf.P[:6, :6]
                continue
            record(k + 1)
            if self.sup is not None:
                self.sup.save(k + 1)
            if progress is not None and k % 50 == 0:
                progress((k + 1) / (n_t - 1))
        labels = ("dtheta_x", "dtheta_y", "dtheta_z", "dbias_x", "dbias_y", "dbias_z")
        filters = [filt] if mekf is None else [mekf, filt]
        counts = {key: sum(f.counts.get(key, 0) for f in filters) for f in filters for key in f.counts}
        events = {f.name: list(f.events) for f in filters}
        result = _finish(name, rec, self.t_grid, labels, counts, events, filt, wall0)
        if self.sup is not None:
            result.detections = list(self.sup.detections)
            result.validity = [*((f.time, f"{f.sensor} model inconsistent from {f.since:.1f} s (windowed NIS "
                                          f"{f.side})") for f in self.sup.validity.flags),
                               *((t, text) for t, text in self.sup.flags if "model inconsistent" not in text)]
            result.counts["detections"] = len(self.sup.detections)
        return result

    def _attitude_only(self, k: int, rec) -> None:
        mekf, t, t1 = self.mekf, self.t_grid[k], self.t_grid[k + 1]
        j = self.last_gyro[k]
        if j >= 0:
            mekf.predict(t, self.dt, self.grids["gyro"][:, j])
        r = mekf.update(Measurement("star_tracker", t1, self.grids["star_tracker"][:, k + 1], self.R["star_tracker"]))
        rec.flag(k + 1, r)
        rec.q[:, k + 1], rec.P[..., k + 1] = mekf.q_BN, mekf.P[:6, :6]
