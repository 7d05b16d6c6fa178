"""The record every sensor returns: sample times, values, validity flags, units and truth."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from types import MappingProxyType

import numpy as np

from postcapture.core.errors import DimensionError

__all__ = ["Measurements"]


@dataclass(frozen=True, slots=True)
class Measurements:
    """Noisy samples of one sensor, time last.

    Parameters
    ----------
    name : str
        Sensor name (``"star_tracker"``, ``"gyro"``, ...).
    t : array_like, shape (n,)
        Sample instants (s), strictly increasing.
    values : array_like, shape (m, n)
        Measured values, one column per sample; NaN where a sample is missing.
    valid : array_like of bool, shape (n,)
        False where a sample is missing (dropout) and must be skipped.
    units : str or tuple of str
        Unit of each row of ``values`` (one string is repeated for every row), e.g. ``"rad/s"``.
    rate : float
        Nominal sample rate (Hz).
    truth : mapping of str to ndarray, optional
        Extra true quantities at the sample instants, time last (e.g. ``"bias_B"``, shape (3, n)).
        Tests and consistency metrics use them; filters must not.

    Raises
    ------
    DimensionError
        If a shape is inconsistent; the message names the array.
    """

    name: str
    t: np.ndarray
    values: np.ndarray
    valid: np.ndarray
    units: tuple[str, ...]
    rate: float
    truth: Mapping[str, np.ndarray] = field(default_factory=dict)

    def __post_init__(self):
        t = np.asarray(self.t, dtype=float)
        values = np.asarray(self.values, dtype=float)
        valid = np.asarray(self.valid, dtype=bool)
        if t.ndim != 1:
            raise DimensionError(f"{self.name}: `t` must be 1-dimensional; found shape {t.shape}")
        n = t.size
        if values.ndim != 2 or values.shape[1] != n:
            raise DimensionError(f"{self.name}: `values` must have shape (m, {n}); found {values.shape}")
        if valid.shape != (n,):
            raise DimensionError(f"{self.name}: `valid` must have shape ({n},); found {valid.shape}")
        units = (self.units,) * values.shape[0] if isinstance(self.units, str) else tuple(self.units)
        if len(units) != values.shape[0]:
            raise DimensionError(
                f"{self.name}: `units` must give {values.shape[0]} units; found {len(units)}"
            )
        truth = {}
        for key, arr in dict(self.truth).items():
            arr = np.asarray(arr, dtype=float)
            if arr.shape[-1:] != (n,):
                raise DimensionError(
                    f"{self.name}: truth[{key!r}] must have time last with {n} samples; found {arr.shape}"
                )
            truth[key] = arr
        for name, value in (("t", t), ("values", values), ("valid", valid), ("units", units)):
            object.__setattr__(self, name, value)
        object.__setattr__(self, "rate", float(self.rate))
        object.__setattr__(self, "truth", MappingProxyType(truth))

    def __reduce__(self):
        """Pickle with a plain dict (a mappingproxy does not pickle): records go to worker processes."""
        return (self.__class__, (self.name, self.t, self.values, self.valid, self.units, self.rate, dict(self.truth)))

    @property
    def n_samples(self) -> int:
        """Number of samples ``n``."""
        return int(self.t.size)

    @property
    def dim(self) -> int:
        """Dimension ``m`` of one sample."""
        return int(self.values.shape[0])

    @property
    def n_missing(self) -> int:
        """Number of samples flagged invalid."""
        return int(np.count_nonzero(~self.valid))
