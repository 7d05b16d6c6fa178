"""Time grids: sample instants ``t0 + k / rate`` and matching them against other grids.

Time never accumulates in postcapture: every grid is built from an integer counter, and instants of
two grids are matched with a small tolerance (floating-point ``t0 + k*h`` and ``t0 + j*h'`` may differ
in the last bits even when they denote the same instant).
"""

from __future__ import annotations

import numpy as np

from postcapture.core.errors import DimensionError, TimeGridError

__all__ = ["default_tolerance", "sample_times", "match_times", "merge_times"]


def default_tolerance(*grids) -> float:
    """Tolerance (s) within which two instants count as the same: ``1e-9 * max(1, max |t|)``."""
    scale = 1.0
    for g in grids:
        g = np.asarray(g, dtype=float)
        if g.size:
            scale = max(scale, float(np.max(np.abs(g))))
    return 1e-9 * scale


def _as_grid(t, name: str) -> np.ndarray:
    t = np.asarray(t, dtype=float)
    if t.ndim != 1:
        raise DimensionError(f"`{name}` must be 1-dimensional; found shape {t.shape}")
    if t.size > 1 and not np.all(np.diff(t) > 0):
        raise TimeGridError(f"`{name}` must be strictly increasing")
    if not np.all(np.isfinite(t)):
        raise TimeGridError(f"`{name}` must be finite")
    return t


def sample_times(t_start: float, t_end: float, rate: float) -> np.ndarray:
    """Sample instants ``t_start + k / rate`` for ``k = 0, 1, ...`` up to ``t_end`` (inclusive).

    Parameters
    ----------
    t_start, t_end : float
        First and last admissible instants (s).
    rate : float
        Sample rate (Hz), positive.

    Returns
    -------
    t : ndarray, shape (n,)
        The instants (s); ``t_end`` is included when it lies on the grid within :func:`default_tolerance`.

    Raises
    ------
    ValueError
        If ``rate`` is not positive or ``t_end < t_start``.
    """
    if not rate > 0.0:
        raise ValueError(f"`rate` must be positive; found {rate}")
    if t_end < t_start:
        raise ValueError(f"`t_end` ({t_end}) must not precede `t_start` ({t_start})")
    tol = default_tolerance([t_start, t_end])
    n = int(np.floor((t_end - t_start) * rate + tol * rate)) + 1
    t = t_start + np.arange(n) / rate
    return t[t <= t_end + tol]


def match_times(t_query, t_grid, *, tol: float | None = None, name: str = "t") -> np.ndarray:
    """Indices ``i`` with ``t_grid[i] == t_query[k]`` within ``tol``, for every query instant.

    Parameters
    ----------
    t_query : array_like, shape (m,)
        Instants to find (s).
    t_grid : array_like, shape (n,)
        Strictly increasing grid (s).
    tol : float, optional
        Matching tolerance (s); :func:`default_tolerance` of both grids by default.
    name : str
        Name of the query used in error messages.

    Returns
    -------
    idx : ndarray of int, shape (m,)

    Raises
    ------
    TimeGridError
        If an instant is not on the grid; the message gives how many and the first ones.
    """
    tq = np.asarray(t_query, dtype=float).reshape(-1)
    tg = _as_grid(t_grid, "t_grid")
    if tol is None:
        tol = default_tolerance(tq, tg)
    if tg.size == 0:
        if tq.size:
            raise TimeGridError(f"{name}: the time grid is empty")
        return np.zeros(0, dtype=int)
    right = np.clip(np.searchsorted(tg, tq), 0, tg.size - 1)
    left = np.clip(right - 1, 0, tg.size - 1)
    idx = np.where(np.abs(tg[left] - tq) <= np.abs(tg[right] - tq), left, right)
    bad = np.abs(tg[idx] - tq) > tol
    if np.any(bad):
        first = ", ".join(f"{v:.9g}" for v in tq[bad][:3])
        raise TimeGridError(
            f"{name}: {int(bad.sum())} of {tq.size} instants are not on the time grid "
            f"[{tg[0]:.9g}, {tg[-1]:.9g}] s within {tol:.3g} s (first: {first} s); "
            "simulate the truth on a grid that contains every sample instant"
        )
    return idx


def merge_times(*grids, tol: float | None = None) -> tuple[np.ndarray, list[np.ndarray]]:
    """Merge several increasing grids into one, identifying instants closer than ``tol``.

    Parameters
    ----------
    *grids : array_like, each shape (n_i,)
        Increasing time grids (s).
    tol : float, optional
        Instants closer than this (s) are merged; :func:`default_tolerance` by default.

    Returns
    -------
    t : ndarray, shape (n,)
        The merged, strictly increasing grid (the first instant of each cluster).
    index : list of ndarray of int
        ``index[i][k]`` is the position in ``t`` of ``grids[i][k]``.
    """
    arrays = [np.asarray(g, dtype=float).reshape(-1) for g in grids]
    if tol is None:
        tol = default_tolerance(*arrays)
    allt = np.concatenate(arrays) if arrays else np.zeros(0)
    order = np.argsort(allt, kind="stable")
    s = allt[order]
    new = np.ones(s.size, dtype=bool)
    new[1:] = np.diff(s) > tol
    gid = np.cumsum(new) - 1
    group = np.empty(s.size, dtype=int)
    group[order] = gid
    bounds = np.cumsum([0] + [a.size for a in arrays])
    return s[new], [group[bounds[i] : bounds[i + 1]] for i in range(len(arrays))]
