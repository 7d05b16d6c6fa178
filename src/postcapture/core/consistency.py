r"""Filter consistency metrics: NEES, NIS, RMS, 3-sigma containment and chi-square bounds.

A consistent filter's normalised estimation error squared (NEES) ``e^T P^-1 e`` is chi-square
distributed with ``n`` degrees of freedom (``n`` = state dimension). Averaged over ``N`` independent
Monte Carlo runs, ``N`` times the mean is chi-square with ``N n`` degrees of freedom, which gives the
two-sided acceptance band of Bar-Shalom, Li and Kirubarajan (2001), section 5.4.2:

.. math::

    \left[\frac{\chi^2_{N n}(\alpha/2)}{N}, \frac{\chi^2_{N n}(1 - \alpha/2)}{N}\right].

The same holds for the normalised innovation squared (NIS) with ``n`` the measurement dimension.

References
----------
Y. Bar-Shalom, X. R. Li, T. Kirubarajan, *Estimation with Applications to Tracking and
Navigation*, Wiley, 2001, ch. 5.4.
"""

from __future__ import annotations

import warnings

import numpy as np
from scipy.stats import chi2

from postcapture.core.errors import DimensionError

__all__ = ["nees", "nis", "rms", "fraction_inside", "chi2_bounds", "run_averaged_nees"]


def nees(error, P):
    """Normalised estimation error squared ``e^T P^-1 e`` at one instant or along a history.

    Parameters
    ----------
    error : array_like, shape (n,) or (n, k)
        Estimation error (estimate minus truth, or its box-minus for attitudes), time last.
    P : array_like, shape (n, n) or (n, n, k)
        Covariance of the estimate, time last.

    Returns
    -------
    float or ndarray, shape (k,)
        NaN where the error or the covariance is not finite.

    Raises
    ------
    DimensionError
        If the shapes do not match.
    """
    e = np.asarray(error, dtype=float)
    P = np.asarray(P, dtype=float)
    single = e.ndim == 1
    n = e.shape[0]
    expected = (n, n) if single else (n, n, e.shape[1])
    if P.shape != expected:
        raise DimensionError(f"Incompatible dimensions of P matrix; expected {expected} but found {P.shape}")
    if single:
        e, P = e[:, None], P[:, :, None]
    k = e.shape[1]
    out = np.full(k, np.nan)
    ok = np.all(np.isfinite(e), axis=0) & np.all(np.isfinite(P), axis=(0, 1))
    if np.any(ok):
        Pk = np.moveaxis(P[:, :, ok], -1, 0)  # (k_ok, n, n)
        ek = e[:, ok].T[:, :, None]  # (k_ok, n, 1)
        out[ok] = np.einsum("ki,ki->k", ek[:, :, 0], np.linalg.solve(Pk, ek)[:, :, 0])
    return float(out[0]) if single else out


def nis(innovation, S):
    """Normalised innovation squared ``nu^T S^-1 nu``; same shapes and rules as :func:`nees`."""
    return nees(innovation, S)


def rms(error, *, axis: int = -1):
    """Root mean square along ``axis`` (time by default), ignoring NaN samples."""
    e = np.asarray(error, dtype=float)
    return np.sqrt(np.nanmean(e * e, axis=axis))


def fraction_inside(error, sigma, *, n_sigma: float = 3.0):
    """Share of samples with ``|error| <= n_sigma * sigma``, per component (NaN samples ignored).

    Parameters
    ----------
    error : array_like, shape (n, k)
        Estimation error, time last.
    sigma : array_like, shape (n, k)
        Standard deviation the filter claims for each component (for example ``sqrt(diag P)``).
    n_sigma : float
        Width of the envelope in standard deviations.

    Returns
    -------
    ndarray, shape (n,)
        Fractions in [0, 1]; a Gaussian consistent filter gives about 0.9973 at 3 sigma.
    """
    e = np.asarray(error, dtype=float)
    s = np.asarray(sigma, dtype=float)
    if e.shape != s.shape:
        raise DimensionError(
            f"Incompatible dimensions of sigma array; expected {e.shape} but found {s.shape}"
        )
    valid = np.isfinite(e) & np.isfinite(s)
    inside = (np.abs(e) <= n_sigma * s) & valid
    with np.errstate(invalid="ignore", divide="ignore"):
        return inside.sum(axis=-1) / valid.sum(axis=-1)


def chi2_bounds(dim: int, n_runs: int = 1, *, alpha: float = 0.05) -> tuple[float, float]:
    """Two-sided ``1 - alpha`` band of a NEES/NIS averaged over ``n_runs`` independent runs.

    Parameters
    ----------
    dim : int
        Dimension ``n`` of the error (state for NEES, measurement for NIS).
    n_runs : int
        Number ``N`` of independent samples averaged (Monte Carlo runs).
    alpha : float
        Total probability outside the band (0.05 for 95 %).

    Returns
    -------
    (lower, upper) : tuple of float
        ``chi2.ppf([alpha/2, 1 - alpha/2], N n) / N``.

    Examples
    --------
    >>> [round(b, 2) for b in chi2_bounds(3, 50)]
    [2.36, 3.72]
    """
    if dim < 1 or n_runs < 1:
        raise ValueError(f"`dim` and `n_runs` must be positive; found dim={dim}, n_runs={n_runs}")
    if not 0.0 < alpha < 1.0:
        raise ValueError(f"`alpha` must lie in (0, 1); found {alpha}")
    lo, hi = chi2.ppf([alpha / 2.0, 1.0 - alpha / 2.0], dim * n_runs) / n_runs
    return float(lo), float(hi)


def run_averaged_nees(nees, t, stop_at) -> np.ndarray:
    """The NEES of many runs averaged over the runs at each instant, every run's samples from its
    ``stop_at`` on left out (a filter that has diverged: its covariance no longer says anything about its
    error, and a re-initialised filter's first seconds would swamp the mean).

    Parameters
    ----------
    nees : array_like, shape (runs, n)
    t : array_like, shape (n,)
    stop_at : array_like, shape (runs,)
        Time from which each run is left out; NaN keeps the whole run.

    Returns
    -------
    ndarray, shape (n,)
        NaN where no run is left.
    """
    z = np.array(nees, dtype=float)
    stop = np.asarray(stop_at, dtype=float)
    z[np.asarray(t, dtype=float)[None, :] >= np.where(np.isnan(stop), np.inf, stop)[:, None]] = np.nan
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)  # instants where every run is left out
        return np.nanmean(z, axis=0)

