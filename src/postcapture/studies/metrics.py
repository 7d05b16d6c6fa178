"""Figures of merit of one estimation case against the truth."""

from __future__ import annotations

import warnings

import numpy as np

from postcapture.core import rotations as rot
from postcapture.core.consistency import chi2_bounds

__all__ = ["ARCSEC", "settle_time", "case_metrics", "finite_or_none"]

ARCSEC = np.pi / (180.0 * 3600.0)


def finite_or_none(value):
    """A float, or None when it is not finite (JSON has no NaN)."""
    if value is None:
        return None
    value = float(value)
    return value if np.isfinite(value) else None


def settle_time(t: np.ndarray, error: np.ndarray, threshold: float) -> float | None:
    """First time after which ``|error| <= threshold`` holds to the end (None if it never settles)."""
    bad = np.nonzero(~(np.abs(error) <= threshold))[0]
    if bad.size == 0:
        return float(t[0])
    if bad[-1] == t.size - 1:
        return None
    return float(t[bad[-1] + 1])


def case_metrics(result, q_true: np.ndarray, m_true: float, steady_from: float = 0.5) -> dict:
    """Metrics of a case; see :func:`_case_metrics`. A diverged filter's NaN tail gives None, not warnings."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)  # means of all-NaN windows of a diverged filter
        return _case_metrics(result, q_true, m_true, steady_from)


def _case_metrics(result, q_true: np.ndarray, m_true: float, steady_from: float = 0.5) -> dict:
    """Metrics of a case (a :class:`~postcapture.estimation.dual.DualResult`).

    Attitude figures use the body-frame error ``box_minus(q_true, q_est)`` against the filter's own
    attitude covariance; "steady" figures use the run after ``steady_from`` of its duration: the error's
    RMS per body axis and the filter's own sigma (RMS of its 1-sigma) over that window.
    ``attitude_inside_3sigma_fraction`` is the share of instants at which every axis's error is within the
    filter's 3 sigma; ``mass_inside_3sigma`` whether the final mass error is within its.
    """
    hist = result.attitude
    t = hist.t
    ok = np.all(np.isfinite(hist.q_BN), axis=0)
    e = np.full((3, t.size), np.nan)
    e[:, ok] = rot.box_minus(q_true[:, ok], hist.q_BN[:, ok])
    P = hist.P[:3, :3, :]
    sig = np.sqrt(np.einsum("iik->ik", P))
    inside = np.all(np.abs(e) <= 3.0 * sig, axis=0)
    with np.errstate(invalid="ignore"):
        nees = np.array([e[:, k] @ np.linalg.solve(P[:, :, k], e[:, k]) if ok[k] else np.nan for k in range(t.size)])
    steady = t >= t[0] + steady_from * (t[-1] - t[0])
    ang = np.linalg.norm(e, axis=0)
    mass_err = result.mass - m_true
    nees_m = (mass_err / result.mass_sigma) ** 2
    lo3, hi3 = chi2_bounds(3, 1)
    last = np.nonzero(np.isfinite(result.mass))[0]
    last = last[-1] if last.size else -1
    err_m, sig_m = float(mass_err[last]), float(result.mass_sigma[last])
    out = {
        "mass_error_kg": err_m,
        "mass_sigma_kg": sig_m,
        "mass_inside_3sigma": bool(abs(err_m) <= 3.0 * sig_m) if np.isfinite(err_m) and np.isfinite(sig_m) else None,
        "mass_error_at_s": float(t[last]),
        "mass_nees_mean": float(np.nanmean(nees_m[1:])),
        "settle_1pct_s": settle_time(t, mass_err, 0.01 * m_true),
        "settle_01pct_s": settle_time(t, mass_err, 0.001 * m_true),
        "attitude_rms_arcsec": float(np.sqrt(np.nanmean(ang**2)) / ARCSEC),
        "attitude_rms_steady_arcsec": float(np.sqrt(np.nanmean(ang[steady] ** 2)) / ARCSEC),
        "attitude_error_rms_steady_arcsec": [finite_or_none(v)
                                             for v in np.sqrt(np.nanmean(e[:, steady] ** 2, axis=1)) / ARCSEC],
        "attitude_sigma_steady_arcsec": [finite_or_none(v)
                                         for v in np.sqrt(np.nanmean(sig[:, steady] ** 2, axis=1)) / ARCSEC],
        "attitude_inside_3sigma_fraction": float(np.mean(inside[ok])),
        "nees_mean": float(np.nanmean(nees)),
        "nees_band_single_run": [float(lo3), float(hi3)],
        "nis_mean": float(np.nanmean(hist.nis)) if np.isfinite(hist.nis).any() else None,
        "mass_nis_mean": float(np.nanmean(result.mass_nis)) if np.isfinite(result.mass_nis).any() else None,
        "star_updates": int(result.counts.get("updates", 0)),
        "rejected": int(result.counts.get("rejected", 0)),
        "success": bool(hist.success),
        "message": hist.message,
        "detections": [{"time_s": d.time, "onset_s": d.onset, "sensor": d.sensor, "channel": d.channel,
                        "size": d.size, "action": d.action, "text": d.describe()}
                       for d in getattr(result, "detections", ())],
        "model_inconsistent": [{"time_s": float(tt), "text": text} for tt, text in getattr(result, "validity", ())],
        "wall_s": float(result.wall_s),
    }
    return {k: (finite_or_none(v) if isinstance(v, float) else v) for k, v in out.items()}
