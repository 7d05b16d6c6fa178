"""What attitude filters read (:class:`SampledSignal`) and return (:class:`EstimateHistory`), time last."""

from __future__ import annotations

import enum
from collections.abc import Mapping
from dataclasses import dataclass, field
from types import MappingProxyType
from typing import Protocol

import numpy as np

from postcapture.core import rotations as rot
from postcapture.core.consistency import nees
from postcapture.core.errors import DimensionError

__all__ = ["SampledSignal", "StepFlag", "EstimateHistory"]


class SampledSignal(Protocol):
    """A sensor record as filters read it; ``postcapture.sensors.Measurements`` satisfies it.

    Attributes
    ----------
    t : ndarray, shape (n,)
        Sample instants (s).
    values : ndarray, shape (m, n)
        Samples, NaN where missing.
    valid : ndarray of bool, shape (n,)
        False where a sample is missing.
    """

    t: np.ndarray
    values: np.ndarray
    valid: np.ndarray


class StepFlag(enum.IntFlag):
    """What happened at one output instant (bits, combined with ``|``)."""

    NONE = 0
    UPDATED = 1
    """A measurement was processed."""
    MEASUREMENT_MISSING = 2
    """A measurement was due but missing or not finite: skipped."""
    REJECTED = 4
    """A measurement was rejected by the chi-square innovation gate."""
    INPUT_MISSING = 8
    """The propagation input (gyro) was missing: the previous sample was held."""
    DIVERGED = 16
    """The filter diverged here; later columns are NaN."""


@dataclass(frozen=True, slots=True)
class EstimateHistory:
    """Output of an attitude filter run, time last.

    Parameters
    ----------
    filter_name : str
        Name of the filter (``"mekf"``, ``"ekf"``, ...).
    t : ndarray, shape (n,)
        Output instants (s).
    q_BN : ndarray, shape (4, n)
        Estimated attitude of B relative to N, scalar-first, after the update at each instant.
    P : ndarray, shape (m, m, n)
        Error-state covariance after the update; the first three error components are the attitude
        error in body components (rad), as ``box_minus(q_true, q_est)``.
    nis : ndarray, shape (n,)
        NIS of the measurement processed at each instant (NaN where none was).
    flags : ndarray of uint8, shape (n,)
        :class:`StepFlag` bits.
    error_labels : tuple of str
        Name of each of the ``m`` error-state components.
    states : mapping of str to ndarray, each shape (k_i, n)
        Other estimated states (``"gyro_bias_B"`` for the MEKF, rates or mass for other filters).
    counts : mapping of str to int
        Event counters (``"updates"``, ``"rejected"``, ``"measurements_missing"``, ``"inputs_missing"``).
    success : bool
        False when the run stopped on a divergence (with ``raise_on_divergence=False``).
    status : int
        0 on success, -1 on divergence.
    message : str
        Human-readable outcome.
    events : tuple of FilterEvent
        Recoveries, divergences and re-initialisations, with times and causes.
    """

    filter_name: str
    t: np.ndarray
    q_BN: np.ndarray
    P: np.ndarray
    nis: np.ndarray
    flags: np.ndarray
    error_labels: tuple[str, ...]
    states: Mapping[str, np.ndarray] = field(default_factory=dict)
    counts: Mapping[str, int] = field(default_factory=dict)
    success: bool = True
    status: int = 0
    message: str = "completed"
    events: tuple = ()

    def __post_init__(self):
        n = np.asarray(self.t).size
        m = len(self.error_labels)
        expected = {"q_BN": (4, n), "P": (m, m, n), "nis": (n,), "flags": (n,)}
        for name, shape in expected.items():
            if np.shape(getattr(self, name)) != shape:
                found = np.shape(getattr(self, name))
                raise DimensionError(f"EstimateHistory.{name}: expected shape {shape}, found {found}")
        for key, arr in self.states.items():
            if np.shape(arr)[-1:] != (n,):
                raise DimensionError(f"EstimateHistory.states[{key!r}]: time must be last with {n} samples")
        object.__setattr__(self, "states", MappingProxyType(dict(self.states)))
        object.__setattr__(self, "counts", MappingProxyType(dict(self.counts)))

    def __reduce__(self):
        """Pickle with plain dicts (a mappingproxy does not pickle): results cross process boundaries."""
        fields = [getattr(self, f) for f in self.__dataclass_fields__]
        fields = [dict(v) if isinstance(v, MappingProxyType) else v for v in fields]
        return (self.__class__, tuple(fields))

    @property
    def sigmas(self) -> np.ndarray:
        """Standard deviations ``sqrt(diag P)``, shape (m, n)."""
        return np.sqrt(np.einsum("iik->ik", self.P))

    def attitude_error(self, q_BN_true) -> np.ndarray:
        """Attitude error ``box_minus(q_true, q_est)`` in body components (rad), shape (3, n).

        Parameters
        ----------
        q_BN_true : array_like, shape (4, n)
            True attitude at the output instants.
        """
        q_true = np.asarray(q_BN_true, dtype=float)
        if q_true.shape != self.q_BN.shape:
            raise DimensionError(f"q_BN_true: expected shape {self.q_BN.shape}, found {q_true.shape}")
        return rot.box_minus(q_true, self.q_BN)

    def nees(self, error) -> np.ndarray:
        """NEES of an error history against ``P`` (or its leading block), shape (n,).

        Parameters
        ----------
        error : array_like, shape (k, n)
            Error of the first ``k`` error-state components (truth minus estimate, box-minus for the
            attitude), ``k <= m``.
        """
        e = np.asarray(error, dtype=float)
        k = e.shape[0]
        return nees(e, self.P[:k, :k, :])

    def flagged(self, flag: StepFlag) -> np.ndarray:
        """Boolean mask (n,) of the instants where ``flag`` is set."""
        return (self.flags & int(flag)) != 0
