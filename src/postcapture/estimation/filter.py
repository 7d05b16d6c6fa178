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

The arithmetic of every filter and this failure model run in the compiled engine (``dynamics/csrc``,
``pc_filter.h``): the classes here and beside it are thin wrappers that hold the configuration, word the
engine's events, keep the counts and log.
"""

from __future__ import annotations

import ctypes
import enum
import logging
from dataclasses import dataclass
from functools import lru_cache

import numpy as np
from scipy.stats import chi2

from postcapture.core.kalman import UpdateResult
from postcapture.core.units import DEG_PER_HOUR
from postcapture.dynamics import engine as _engine

__all__ = ["FilterStatus", "Measurement", "FilterEvent", "RecoveryPolicy", "FilterBase", "KINDS", "state_view"]

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


def state_view(attr: str, doc: str) -> property:
    """A property over one of a filter's views of the engine's state: it reads a copy and writes in place."""

    def get(self) -> np.ndarray:
        return getattr(self, attr).copy()

    def put(self, value) -> None:
        getattr(self, attr)[...] = np.asarray(value, dtype=float)

    return property(get, put, doc=doc)


KINDS = ("star_tracker", "gyro", "accelerometer", "encoders", "accelerations")
"""Measurement kinds, in the engine's numbering."""

_EVENT_TYPES = ("recovering", "recovered", "diverged", "reinitialised")
_COUNTS = ("updates", "rejected", "measurements_missing", "recoveries", "divergences", "inputs_missing")
_STATUS = (FilterStatus.RUNNING, FilterStatus.RECOVERING, FilterStatus.DIVERGED)  # the engine's numbering


@lru_cache(maxsize=64)
def _chi2_table(probability: float, n: int) -> np.ndarray:
    """``chi2.ppf(probability, d)`` for ``d = 0 .. n - 1`` (infinite at 0), computed once per process."""
    table = np.full(n, np.inf)
    table[1:] = chi2.ppf(probability, np.arange(1, n))
    table.setflags(write=False)
    return table


def _word(kind: int, cause: int, n: int, a: float, b: float, text: str) -> str:
    """The text of an event's cause (``pc_filter.h``'s PC_CAUSE_*)."""
    name = KINDS[kind] if 0 <= kind < len(KINDS) else "?"
    if cause == 0:
        return f"{n} {name} samples in a row rejected by the gate (last NIS {a:.3g})"
    if cause == 1:
        return f"{name} innovations too large for their covariance (mean NIS {a:.3g} over {n} updates, {b:g} dof each)"
    if cause == 2:
        return f"{name} innovations consistent again"
    if cause == 4:
        return f"covariance not finite or with a negative variance after the {'update' if n else 'prediction'}"
    if cause == 5:
        return "innovation covariance S is not finite"
    if cause == 6:
        return "innovation covariance S = H P H^T + R is not positive definite"
    if cause == 7:
        return f"the plant copy failed: {text}"
    return "from the next measurements"


class FilterBase:
    """What every filter shares: its engine handle, status, events, counts and the recovery policy.

    Subclasses create their engine filter with :meth:`_policy` and hand it to :meth:`_attach`; after every
    engine call they call :meth:`_sync`, which takes the engine's status, counts and events (worded here)
    and logs them. ``counts`` is a plain dict: a scheme may add its own entries.
    """

    _S_PREFIX = False  # word a singular innovation covariance as "<kind> update: ..."

    def _init_base(self, name: str, policy: RecoveryPolicy | None, gate_probability: float | None):
        self.name = name
        self.status = FilterStatus.RUNNING
        self.events: list[FilterEvent] = []
        self.policy = policy or RecoveryPolicy()
        self.gate_probability = gate_probability
        self.counts = {"updates": 0, "rejected": 0, "measurements_missing": 0, "recoveries": 0, "divergences": 0}
        self._seen = [0] * len(_COUNTS)  # the engine's counts at the last _sync
        self._counts_buf = np.zeros(len(_COUNTS), dtype=np.int64)
        self._handle = None
        self._eng = _engine.engine()
        # the buffers of the calls made every cycle: allocated here once and never replaced, so that their
        # addresses are taken once (the calls by address: ``Engine.by_address``); the views read the outcome
        self._res = _engine.UpdateStruct()
        self._res_nu = np.ctypeslib.as_array(self._res.innovation)
        self._res_S = np.ctypeslib.as_array(self._res.S)
        self._event_nums = np.zeros((16, _engine.EVENT_DOUBLES))
        self._event_text = ctypes.create_string_buffer(16 * _engine.EVENT_TEXT)
        self._addr = {"res": ctypes.addressof(self._res), "counts": self._counts_buf.ctypes.data,
                      "event_nums": self._event_nums.ctypes.data, "event_text": ctypes.addressof(self._event_text)}
        self._status_call = self._eng.by_address("filter_status")
        self._events_call = self._eng.by_address("filter_events")

    def _policy(self, max_m: int) -> _engine.PolicyStruct:
        """The engine's policy for measurements of at most ``max_m`` components."""
        pol = self.policy
        gate = np.zeros(max_m) if self.gate_probability is None else _chi2_table(float(self.gate_probability),
                                                                                  max_m + 1)[1:]
        bound = _chi2_table(float(pol.nis_probability), pol.nis_window * max_m + 1) if pol.nis_window else np.zeros(1)
        self._tables = (np.ascontiguousarray(gate), np.ascontiguousarray(bound))  # alive while the struct is
        dp = ctypes.POINTER(ctypes.c_double)
        return _engine.PolicyStruct(
            pol.reject_limit, pol.nis_window, pol.max_recoveries, int(self.gate_probability is not None), max_m,
            self._tables[1].size, pol.inflation, pol.gyro_bias_bump, pol.recovery_window,
            self._tables[0].ctypes.data_as(dp), self._tables[1].ctypes.data_as(dp))

    def _attach(self, handle) -> None:
        if not handle:
            raise MemoryError(f"{self.name}: the engine could not create the filter")
        self._handle = handle
        size = ctypes.c_size_t()
        ptr = self._eng.filter_state(handle, ctypes.byref(size))
        self._state = np.ctypeslib.as_array(ptr, shape=(size.value,))  # the engine's own memory, a live view

    def __del__(self):
        handle, eng = getattr(self, "_handle", None), getattr(self, "_eng", None)
        if handle and eng is not None:
            eng.filter_destroy(handle)
            self._handle = None

    def _sync(self) -> None:
        """Status, counts and events from the engine (after every call that may change them)."""
        h, addr = self._handle, self._addr
        status = self._status_call(h, addr["counts"])
        counts = self._counts_buf.tolist()
        if counts != self._seen:
            for key, c, seen in zip(_COUNTS, counts, self._seen):
                if c != seen:
                    self.counts[key] = self.counts.get(key, 0) + c - seen
            self._seen = counts
        self.status = _STATUS[status]
        nums, text = self._event_nums, self._event_text  # read out before the next call overwrites them
        while True:
            n = self._events_call(h, addr["event_nums"], addr["event_text"], 16)
            for i in range(n):
                self._event(nums[i], text.raw[i * _engine.EVENT_TEXT:(i + 1) * _engine.EVENT_TEXT])
            if n < 16:
                break

    def _event(self, e: np.ndarray, raw: bytes) -> None:
        t, kind, cause, who = float(e[0]), _EVENT_TYPES[int(e[1])], int(e[2]), int(e[3])
        text = raw.split(b"\0", 1)[0].decode(errors="replace")
        if cause == 3:  # too many recoveries: the last one's cause inside
            inner = _word(int(e[8]), int(e[7]), int(e[9]), float(e[10]), float(e[11]), "")
            words = f"{int(e[4])} recoveries within {float(e[5]):g} s; last: {inner}"
        else:
            words = _word(who, cause, int(e[4]), float(e[5]), float(e[6]), text)
            if cause in (5, 6) and self._S_PREFIX:
                words = f"{KINDS[int(e[4])]} update: {words}"
        self.events.append(FilterEvent(t, kind, words))
        if kind == "recovering":
            logger.warning("%s: recovering at t = %.6g s: %s", self.name, t, words)
        elif kind == "diverged":
            logger.error("%s diverged at t = %.6g s: %s", self.name, t, words)

    def _result(self, kind: str, t: float, K=None) -> UpdateResult | None:
        """The engine's last update as an :class:`~postcapture.core.kalman.UpdateResult` (None when missing)."""
        r = self._res
        self._sync()
        if r.missing:
            return None
        m = r.m
        S = self._res_S[: m * m].reshape(m, m).copy()
        nu = self._res_nu[:m].copy()
        if not r.accepted:
            logger.info("%s: %s sample at t = %.6g s rejected (NIS %.3g)", self.name, kind, t, r.nis)
        return UpdateResult(None, None, nu, S, K, float(r.nis), bool(r.accepted),
                            None if r.threshold < 0 else float(r.threshold))

    P = state_view("_P", "Error covariance over :attr:`labels` (a copy; assigning writes the engine's).")

    def snapshot(self) -> np.ndarray:
        """The filter's state (estimate and covariance, not its failure model's), to :meth:`restore`."""
        return self._state.copy()

    def restore(self, snap) -> None:
        """Back to a :meth:`snapshot` (a fault found late is re-processed from there)."""
        self._state[:] = snap

    @property
    def diverged_at(self) -> float | None:
        """Time of the first divergence (None if none)."""
        for e in self.events:
            if e.kind == "diverged":
                return e.t
        return None
