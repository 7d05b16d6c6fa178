"""What every filter shares: one stepper interface, one failure model, named coordinates, recovery.

Every filter is a stepper::

    filt.predict(t, dt, u=None)       # advance from t to t + dt with the step's known input u
    filt.update(Measurement(...))     # correct with one measurement and its noise

and exposes ``labels`` (the names of its error-state coordinates), ``P`` (their covariance), ``status``
(:class:`FilterStatus`) and ``events`` (what happened, with times and causes). Schemes (dual, joint)
are compositions of these steppers.

Failure model
-------------
A measurement whose NIS lies outside the chi-square gate is rejected. Rejections in a row, or a run
of accepted innovations too large for their covariance (the windowed NIS far above its chi-square bound),
mean that the filter's covariance no longer covers its error: the filter *recovers*: it inflates the
covariance blocks that measurement informs (and bumps the process noise of the biases it carries), so
that the gate widens with the covariance, with status ``RECOVERING`` until a window of innovations is
consistent again. A burst of bad samples stays gated; an error the filter really has is let in as
the covariance grows. When recoveries do not help (``max_recoveries`` within ``recovery_window``
seconds) or the covariance stops being finite, the filter has *diverged*: the event is recorded with
its time and cause, the filter re-initialises (its next measurement of each kind is let through
without a gate: re-acquisition), and the run goes on.
"""

from __future__ import annotations

import enum
import logging
from collections import deque
from dataclasses import dataclass
from functools import lru_cache

import numpy as np
from scipy.stats import chi2

from postcapture.core.units import DEG_PER_HOUR

__all__ = ["FilterStatus", "Measurement", "FilterEvent", "RecoveryPolicy", "FilterBase"]

logger = logging.getLogger(__name__)


class FilterStatus(enum.Enum):
    """Health of a filter."""

    RUNNING = "running"
    RECOVERING = "recovering"
    DIVERGED = "diverged"


@dataclass(frozen=True)
class Measurement:
    """One measurement: its kind, time (s), value (NaN entries are missing) and noise covariance.

    Kinds: ``"star_tracker"`` (4, q_BN), ``"gyro"`` (3, rad/s, the mean rate over the step that ends at
    ``t``), ``"accelerations"`` (3 + n_arm: accelerometer m/s^2 then joint accelerations rad/s^2).
    A filter that does not own the measurement's model (a parameter filter beside a plant copy) is given
    it linearised: ``value`` is then the innovation ``z - h(x)`` and ``H`` its Jacobian with respect to the
    filter's own quantity.
    """

    kind: str
    t: float
    value: np.ndarray
    R: np.ndarray
    H: np.ndarray | None = None


@dataclass(frozen=True)
class FilterEvent:
    """Something that happened to a filter: ``kind`` is recovering, recovered, diverged or reinitialised."""

    t: float
    kind: str
    cause: str


@dataclass(frozen=True)
class RecoveryPolicy:
    """When and how a filter recovers (see the module docstring).

    Parameters
    ----------
    reject_limit : int
        Rejections in a row of one kind of measurement that start a recovery.
    nis_window : int
        Accepted updates of one kind whose summed NIS is tested against its chi-square bound at
        ``nis_probability`` (0 switches the test off).
    nis_probability : float
        Probability of that bound: innovations of a filter are correlated in time, so the bound sits far
        out (1 - 1e-6) to keep false alarms rare over thousands of windows.
    inflation : float
        Factor on the covariance blocks a recovery inflates.
    gyro_bias_bump : float
        1-sigma (rad/s) added to a carried gyro bias by a recovery from star-tracker or gyro innovations:
        a factor alone does little to a bias variance that has converged far below a bias step's size.
    max_recoveries : int
        Recoveries within ``recovery_window`` seconds that mean divergence.
    recovery_window : float
        Seconds.
    """

    reject_limit: int = 5
    nis_window: int = 50
    nis_probability: float = 1.0 - 1e-6
    inflation: float = 10.0
    gyro_bias_bump: float = DEG_PER_HOUR
    max_recoveries: int = 6
    recovery_window: float = 60.0


@lru_cache(maxsize=256)
def _bound(dof: int, probability: float) -> float:
    return float(chi2.ppf(probability, dof))


class FilterBase:
    """Bookkeeping shared by every filter: status, events, counts, gating and the recovery trigger.

    Subclasses set ``name``, ``labels``, ``P`` and implement ``_recover(kind, t)`` (inflate what a kind
    of measurement informs) and ``_reinitialise(t)``.
    """

    def _init_base(self, name: str, policy: RecoveryPolicy | None, gate_probability: float | None):
        self.name = name
        self.status = FilterStatus.RUNNING
        self.events: list[FilterEvent] = []
        self.policy = policy or RecoveryPolicy()
        self.gate_probability = gate_probability
        self.counts = {"updates": 0, "rejected": 0, "measurements_missing": 0, "recoveries": 0, "divergences": 0}
        self._rejected_in_row: dict[str, int] = {}
        self._nis: dict[str, deque] = {}
        self._recoveries: deque = deque()
        self._reacquire: set[str] = set()

    # ------------------------------------------------------------------ gating and recovery
    def gate(self, kind: str) -> float | None:
        """The gate probability for the next measurement of ``kind`` (None right after a recovery)."""
        if kind in self._reacquire:
            return None
        return self.gate_probability

    def record(self, kind: str, t: float, nis: float, dof: int, accepted: bool) -> None:
        """Book one update (accepted or rejected) and start a recovery when the innovations say so."""
        self._reacquire.discard(kind)
        if not accepted:
            self.counts["rejected"] += 1
            n = self._rejected_in_row.get(kind, 0) + 1
            self._rejected_in_row[kind] = n
            logger.info("%s: %s sample at t = %.6g s rejected (NIS %.3g)", self.name, kind, t, nis)
            if n >= self.policy.reject_limit:
                self._start_recovery(kind, t, f"{n} {kind} samples in a row rejected by the gate (last NIS {nis:.3g})")
            return
        self.counts["updates"] += 1
        self._rejected_in_row[kind] = 0
        window = self.policy.nis_window
        if not window:
            return
        buf = self._nis.setdefault(kind, deque(maxlen=window))
        buf.append((nis, dof))
        if len(buf) == window:
            total, dofs = sum(x for x, _ in buf), sum(d for _, d in buf)
            if total > _bound(dofs, self.policy.nis_probability):
                self._start_recovery(kind, t, f"{kind} innovations too large for their covariance (mean NIS "
                                              f"{total / window:.3g} over {window} updates, {dofs / window:g} dof each)")
            elif self.status is FilterStatus.RECOVERING:
                self.status = FilterStatus.RUNNING
                self.events.append(FilterEvent(t, "recovered", f"{kind} innovations consistent again"))

    def _start_recovery(self, kind: str, t: float, cause: str) -> None:
        self._rejected_in_row[kind] = 0
        self._nis.pop(kind, None)
        while self._recoveries and self._recoveries[0] < t - self.policy.recovery_window:
            self._recoveries.popleft()
        self._recoveries.append(t)
        if len(self._recoveries) > self.policy.max_recoveries:
            self.diverge(t, f"{len(self._recoveries)} recoveries within {self.policy.recovery_window:g} s; last: {cause}")
            return
        self.counts["recoveries"] += 1
        self.status = FilterStatus.RECOVERING
        self.events.append(FilterEvent(t, "recovering", cause))
        logger.warning("%s: recovering at t = %.6g s: %s", self.name, t, cause)
        self._recover(kind, t)

    def diverge(self, t: float, cause: str) -> None:
        """Record a divergence (time and cause), re-initialise, and go on."""
        self.counts["divergences"] += 1
        self.status = FilterStatus.DIVERGED
        self.events.append(FilterEvent(t, "diverged", cause))
        logger.error("%s diverged at t = %.6g s: %s", self.name, t, cause)
        self._recoveries.clear()
        self._nis.clear()
        self._reinitialise(t)
        self.events.append(FilterEvent(t, "reinitialised", "from the next measurements"))
        self.status = FilterStatus.RECOVERING
        self._reacquire.update(("star_tracker", "gyro", "accelerations"))

    def check_covariance(self, t: float, where: str) -> bool:
        """True when ``P`` is finite with a non-negative diagonal; otherwise a divergence.

        (A covariance may be singular on purpose: a cloned state, a prior on a curve. The Joseph update
        keeps it positive semi-definite; what this catches is a filter gone numerically wrong.)
        """
        P = self.P
        ok = bool(np.all(np.isfinite(P))) and bool(np.all(np.diag(P) >= 0.0))
        if not ok:
            self.diverge(t, f"covariance not finite or with a negative variance after the {where}")
        return ok

    @property
    def diverged_at(self) -> float | None:
        """Time of the first divergence (None if none)."""
        for e in self.events:
            if e.kind == "diverged":
                return e.t
        return None

    # ------------------------------------------------------------------ hooks
    def _recover(self, kind: str, t: float) -> None:  # pragma: no cover - every filter overrides
        raise NotImplementedError

    def _reinitialise(self, t: float) -> None:  # pragma: no cover
        raise NotImplementedError

