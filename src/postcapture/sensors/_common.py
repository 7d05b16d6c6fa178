"""Shared helpers of the sensor models: parameter validation, sampling the truth, dropouts."""

from __future__ import annotations

import math

import numpy as np

from postcapture.core.errors import DimensionError, Problem, ScenarioError
from postcapture.core.timegrid import match_times, sample_times

__all__ = ["Checker", "sample_truth", "apply_dropouts"]


class Checker:
    """Collects every problem of one parameter object, then raises a single :class:`ScenarioError`."""

    def __init__(self, obj):
        self.obj = obj
        self.cls = type(obj).__name__
        self.problems: list[Problem] = []

    def _value(self, name):
        return getattr(self.obj, name)

    def _add(self, name, expected, found):
        self.problems.append(Problem(f"{self.cls}.{name}", expected, repr(found)))

    def number(self, name: str, *, positive: bool = False, below_one: bool = False) -> None:
        """A finite float, ``>= 0`` (``> 0`` if ``positive``; ``< 1`` if ``below_one``); stored as float."""
        value = self._value(name)
        try:
            x = float(value)
        except (TypeError, ValueError):
            self._add(name, "a number", value)
            return
        if not math.isfinite(x) or x < 0.0 or (positive and x == 0.0) or (below_one and x >= 1.0):
            rng = "in [0, 1)" if below_one else ("> 0" if positive else ">= 0")
            self._add(name, f"a finite number {rng}", value)
            return
        object.__setattr__(self.obj, name, x)

    def vector(self, name: str, size: int = 3, *, nonzero: bool = False) -> None:
        """A finite float array of shape ``(size,)``; stored as a read-only ndarray."""
        value = self._value(name)
        try:
            v = np.array(value, dtype=float).reshape(-1)
        except (TypeError, ValueError):
            self._add(name, f"{size} numbers", value)
            return
        if v.shape != (size,) or not np.all(np.isfinite(v)) or (nonzero and not np.any(v)):
            self._add(name, f"{size} finite numbers" + (", not all zero" if nonzero else ""), value)
            return
        v.setflags(write=False)
        object.__setattr__(self.obj, name, v)

    def misalignment(self, name: str) -> None:
        """A finite 3x3 float array with a zero diagonal (the off-axis sensitivities); stored read-only."""
        value = self._value(name)
        try:
            m = np.array(value, dtype=float)
        except (TypeError, ValueError):
            self._add(name, "a 3x3 matrix", value)
            return
        if m.shape != (3, 3) or not np.all(np.isfinite(m)) or np.any(np.diag(m) != 0.0) or np.any(np.abs(m) >= 0.1):
            self._add(name, "a finite 3x3 matrix of small angles (|m| < 0.1 rad) with a zero diagonal", value)
            return
        m.setflags(write=False)
        object.__setattr__(self.obj, name, m)

    def integer(self, name: str) -> None:
        """A positive integer."""
        value = self._value(name)
        if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < 1:
            self._add(name, "a positive integer", value)
            return
        object.__setattr__(self.obj, name, int(value))

    def done(self) -> None:
        """Raise :class:`ScenarioError` listing every problem found, if any."""
        if self.problems:
            raise ScenarioError(self.problems, source=self.cls)


def sample_truth(name, t_truth, arrays, rate, t_start=None, t_end=None):
    """Sample instants ``t_start + k / rate`` and the truth columns at those instants.

    Parameters
    ----------
    name : str
        Sensor name for error messages.
    t_truth : array_like, shape (n_t,)
        Truth time grid (s).
    arrays : dict of str to array_like, each shape (m_i, n_t)
        Truth histories, time last.
    rate : float
        Sample rate (Hz).
    t_start, t_end : float, optional
        First and last admissible sample instants (s); the ends of the truth grid by default.

    Returns
    -------
    t : ndarray, shape (n,)
    sampled : dict of str to ndarray, each shape (m_i, n)

    Raises
    ------
    DimensionError
        If a truth array does not have the truth grid's length on its last axis.
    TimeGridError
        If a sample instant is not on the truth grid.
    """
    t_truth = np.asarray(t_truth, dtype=float)
    if t_truth.ndim != 1 or t_truth.size == 0:
        raise DimensionError(
            f"{name}: the truth time grid must be a non-empty 1-D array; found {t_truth.shape}"
        )
    t0 = t_truth[0] if t_start is None else float(t_start)
    t1 = t_truth[-1] if t_end is None else float(t_end)
    t = sample_times(t0, t1, rate)
    idx = match_times(t, t_truth, name=f"{name} sample times at {rate:g} Hz")
    sampled = {}
    for key, arr in arrays.items():
        arr = np.asarray(arr, dtype=float)
        if arr.ndim != 2 or arr.shape[1] != t_truth.size:
            raise DimensionError(
                f"{name}: truth array `{key}` must have shape (m, {t_truth.size}) (time last); "
                f"found {arr.shape}"
            )
        sampled[key] = arr[:, idx]
    return t, sampled


def apply_dropouts(values: np.ndarray, probability: float, rng: np.random.Generator):
    """Blank each sample (column) with the given probability; return ``(values, valid)``.

    The dropout draws come after the noise draws, so that changing the probability does not change
    the noise on the samples that remain.
    """
    n = values.shape[1]
    valid = np.ones(n, dtype=bool)
    if probability > 0.0:
        valid = rng.random(n) >= probability
        values = values.copy()
        values[:, ~valid] = np.nan
    return values, valid

