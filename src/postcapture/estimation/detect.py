r"""Faults the filters are not told of: change detection on the innovations, and a model-validity monitor.

**Change detection.** A sensor fault a filter does not model (a bias step, a stuck encoder) shows as a
shift in the mean of that sensor's innovations. Each innovation component, normalised by its predicted
standard deviation, ``z = nu_i / sqrt(S_ii)``, feeds a two-sided CUSUM (Page's test; Basseville and
Nikiforov, *Detection of Abrupt Changes*, 1993, section 2.2):

.. math::

    g^+_k = \max(0,\ g^+_{k-1} + z_k - \kappa), \qquad g^-_k = \max(0,\ g^-_{k-1} - z_k - \kappa),

with an alarm when either exceeds ``h``. For unit white innovations and ``kappa = 0.25``, ``h = 25`` the
mean time between false alarms is about 2e6 samples per component (Siegmund's approximation), and a
shift of ``delta`` sigmas is detected after about ``(h + 1.166) / (delta - kappa)`` samples (11 s at 10 Hz
for half a sigma, 2 s for one and a half). The onset is then located by the generalised likelihood ratio
of a step in the mean (Willsky and Jones, IEEE TAC 21(1), 1976, with the filter's own response to the
step neglected): over the samples since the statistic was last zero (and a margin before), the onset
``theta`` maximising ``(sum_{theta..k} z)^2 / (k - theta + 1)``; the shift's size is the mean of ``z``
from there. (The last zero alone can sit well before the change: innovations that are not quite white,
after a thrust ends, start the statistic climbing early.)

The encoders get a larger reference value (``encoder_drift``, 2.5: a shift of five sigmas is what it
looks for). Their faults are gross (a stuck or jumping read-out leaves the moving joint by milliradians,
hundreds of sigmas, within a second), while their innovations carry the time-correlated part of the
model error at a sigma or two for seconds at a time: while the parameters are still being learnt as the
sweeps start, the joints' deflections under a mass the filter does not yet know. With ``kappa = 0.25``,
6 of the first 14 fault-free dispersed Envisat runs isolated a healthy joint between 10 and 25 s.

The accelerometer's innovations are normalised by their own running spread as well (``normalised``):
the derived model error covers the prior's worst draws, so on a typical truth the accelerometer's
innovations spread over about 0.63 of their predicted sigma, and a 15 micro-g bias step after the burn
(0.44 predicted sigmas for a few seconds, before the parameters absorb it) went unseen in 7 of 20
dispersed runs, which then ended up to 4.7 sigma off in the mass. Divided by
``sqrt(mean(z^2))`` over the last 30 s (between 0.3 and 1), the same step is found 7-18 s after it with
its onset within 1.5 s. The predicted sigma is never exceeded as the unit, so a sensor whose
innovations are larger than predicted is left to the validity monitor.

**Model validity.** The normalised innovation squared of each sensor, summed over a sliding window, has a
chi-square distribution when the filter's model holds. :class:`ValidityMonitor` flags a sensor *model
inconsistent* when that sum stays above its two-sided chi-square band for longer than a declared time:
a truth outside the filter's declared uncertainty is then flagged rather than silently wrong. (Below the
band, the filter is more pessimistic than it needs to be, which is the safe side of its model error:
the derived model noise covers the worst of the declared truths, so most runs sit there and are not
flagged.)
"""

from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass, field
from functools import lru_cache

import numpy as np
from scipy.stats import chi2

__all__ = ["DetectionPolicy", "Alarm", "ChangeDetector", "ValidityMonitor", "ValidityFlag"]


@dataclass(frozen=True)
class DetectionPolicy:
    """How faults are detected and handled (see the module docstring).

    Parameters
    ----------
    drift : float
        CUSUM reference value ``kappa`` (in innovation sigmas): half the smallest shift to detect quickly.
    encoder_drift : float
        The same for the joint encoders, whose faults are gross (see the module docstring).
    threshold : float
        CUSUM alarm threshold ``h``.
    isolation_window : float
        Seconds: a sensor whose bias was re-opened and that alarms again within this time is isolated.
    validity_window : float
        Seconds of the sliding NIS sum of the validity monitor.
    validity_probability : float
        Two-sided probability of the chi-square band of that sum.
    validity_time : float
        Seconds outside the band after which a sensor is flagged model inconsistent.
    lookback : float
        Seconds of history kept to re-process from a detected onset.
    normalised : tuple of str
        Sensors whose innovations the detector normalises by their own running spread (see the module
        docstring), over ``normalisation_window`` seconds and by a factor of at least ``normalisation_floor``.
    """

    drift: float = 0.25
    encoder_drift: float = 2.5
    threshold: float = 25.0
    isolation_window: float = 60.0
    validity_window: float = 30.0
    validity_probability: float = 0.999
    validity_time: float = 20.0
    lookback: float = 120.0
    normalised: tuple = ("accelerometer",)
    normalisation_window: float = 30.0
    normalisation_floor: float = 0.3


@dataclass(frozen=True)
class Alarm:
    """A detected change: the component, its onset and alarm times (s) and the shift (innovation sigmas)."""

    component: int
    onset: float
    time: float
    shift: float


class ChangeDetector:
    """Two-sided CUSUM on each of ``m`` normalised innovation components (see the module docstring).

    The statistics are plain Python floats, one list per side (a detector sees a few components at a time,
    thousands of times a run: numpy's per-call cost on arrays of three was most of its time); ``g``,
    ``since``, ``sums`` and ``counts`` read them as (2, m) arrays, side 0 the upper one.
    """

    def __init__(self, m: int, drift: float, threshold: float, memory: int = 1200):
        self.m, self.drift, self.threshold = int(m), float(drift), float(threshold)
        self._history: deque = deque(maxlen=int(memory))  # (t, z per component, NaN where not fed)
        self.reset()

    g = property(lambda self: np.array(self._g, dtype=float), doc="The CUSUM statistics (2, m), upper side first.")
    since = property(lambda self: np.array(self._since, dtype=float), doc="When each statistic left zero (s).")
    sums = property(lambda self: np.array(self._sums, dtype=float), doc="Sum of z since then.")
    counts = property(lambda self: np.array(self._counts, dtype=int), doc="Samples since then.")

    def reset(self, component: int | None = None) -> None:
        """Start over (every component, or one)."""
        if component is None:
            self._history.clear()
            m = self.m
            self._g = [[0.0] * m, [0.0] * m]
            self._since = [[np.nan] * m, [np.nan] * m]
            self._sums = [[0.0] * m, [0.0] * m]
            self._counts = [[0] * m, [0] * m]
        else:
            for side in (0, 1):
                self._g[side][component] = 0.0
                self._since[side][component] = np.nan
                self._sums[side][component] = 0.0
                self._counts[side][component] = 0

    def update(self, t: float, z, components=None) -> list[Alarm]:
        """Feed normalised innovations ``z`` of the given components (all by default); return the alarms."""
        z = np.asarray(z, dtype=float).tolist()
        comp = range(self.m) if components is None else [int(i) for i in components]
        if len(z) != len(comp):
            raise ValueError(f"{len(z)} innovations for {len(comp)} components")
        t = float(t)
        row = [np.nan] * self.m
        for i, x in zip(comp, z):
            row[i] = x
        self._history.append((t, row))
        fired = [(side, i) for side, sign in ((0, 1.0), (1, -1.0)) for i in self._step(side, sign, t, comp, z)]
        return [self._locate(i, self._since[side][i], t) for side, i in fired]

    def _step(self, side: int, sign: float, t: float, comp, z) -> list[int]:
        """One side's statistics after the samples ``z`` of components ``comp``; the components past the
        threshold. ``0.0 if v < 0.0 else v`` is numpy's ``maximum(0.0, v)`` to the bit (a NaN stays NaN)."""
        g, since, sums, counts = self._g[side], self._since[side], self._sums[side], self._counts[side]
        drift, threshold, over = self.drift, self.threshold, []
        for i, x in zip(comp, z):
            v = g[i] + sign * x - drift
            g_new = 0.0 if v < 0.0 else v
            if g_new > 0.0:
                if g[i] == 0.0:  # the statistic starts an excursion here
                    since[i], sums[i], counts[i] = t, 0.0, 0
                sums[i] += x
                counts[i] += 1
            g[i] = g_new
            if g_new > threshold:
                over.append(i)
        return over

    def _locate(self, i: int, since: float, t: float) -> Alarm:
        """The alarm of component ``i``: the onset where a step in the mean is likeliest (see the module
        docstring), searched from twice the CUSUM's excursion back."""
        times = np.array([h[0] for h in self._history])
        z = np.array([h[1][i] for h in self._history])
        ok = np.isfinite(z) & (times >= since - (t - since))
        times, z = times[ok], z[ok]
        if z.size == 0:
            return Alarm(i, since, t, 0.0)
        tail = np.cumsum(z[::-1])[::-1]  # sum from each candidate onset to now
        n = np.arange(z.size, 0, -1)
        best = int(np.argmax(tail**2 / n))
        return Alarm(i, float(times[best]), t, float(tail[best] / n[best]))


@lru_cache(maxsize=None)
def _upper_bound(probability: float, dof: int) -> float:
    """The chi-square quantile a windowed NIS sum is held against (scipy's isf costs 0.1 ms a call)."""
    return float(chi2.isf(probability, dof))


@dataclass
class ValidityFlag:
    """A sensor found model inconsistent: its name, when the windowed NIS left its band, and on which side."""

    sensor: str
    since: float
    time: float
    side: str  # "high": innovations too large for their covariance


class _Window:
    """One sensor's last ``n`` updates (times, NIS, dof) and their sums, kept running.

    The dof sum is exact (ints). The NIS sum decides, and it must be the one the window gives added left to
    right (``sum(values)``, what the monitor has always computed): a running sum differs from it in its last
    bits. So the running sum carries a bound on that difference, and a comparison closer than the bound is
    made on ``sum(values)``. Each rounding of the running sum is at most ``u |result|`` (``u = 2**-53``); a
    left-to-right sum of ``n`` terms is within ``n u sum|x|`` of the exact one (Higham, *Accuracy and
    Stability of Numerical Algorithms*, 2002, section 4.2), with ``sum|x|`` kept running beside. Every term
    is booked at twice its bound. The running sums start again from ``sum(values)`` once a window, so the
    bound stays small: nearly every decision is made on the running sum, and each is the left-to-right sum's.
    """

    __slots__ = ("n", "times", "values", "dofs", "dof_sum", "running", "magnitude", "_rounded", "_base", "_ops")
    _U = 2.0**-53

    def __init__(self, n: int):
        self.n, self.times, self.values, self.dofs = n, deque(), deque(), deque()
        self.dof_sum, self.running, self.magnitude = 0, 0.0, 0.0
        self._rounded, self._base, self._ops = 0.0, 0.0, 0

    def __len__(self) -> int:
        return len(self.times)

    def _add(self, x: float, sign: float) -> None:
        self.running += sign * x
        self.magnitude += sign * abs(x)
        self._rounded += 2.0 * self._U * (abs(self.running) + abs(self.magnitude))
        self._ops += 1

    def append(self, t: float, nis: float, dof: int) -> None:
        """Book an update, the oldest one leaving a full window."""
        if len(self.times) == self.n:
            self.times.popleft()
            self._add(self.values.popleft(), -1.0)
            self.dof_sum -= self.dofs.popleft()
        self.times.append(t)
        self.values.append(nis)
        self.dofs.append(dof)
        self._add(nis, 1.0)
        self.dof_sum += dof
        if self._ops >= self.n:
            self._exact()

    def drop_after(self, t: float) -> None:
        """Forget the updates after ``t``."""
        while self.times and self.times[-1] > t:
            self.times.pop()
            self._add(self.values.pop(), -1.0)
            self.dof_sum -= self.dofs.pop()

    def _exact(self) -> float:
        """The NIS sum added left to right; the running sums start again from it."""
        self.running = sum(self.values)
        self.magnitude = sum(map(abs, self.values))
        self._base = 2.0 * len(self.values) * self._U * self.magnitude
        self._rounded, self._ops = 0.0, 0
        return self.running

    def exceeds(self, bound: float) -> bool:
        """``sum(values) > bound``: from the running sum when it is farther from ``bound`` than its error."""
        margin = self._rounded + self._base + 2.0 * len(self.values) * self._U * abs(self.magnitude)
        gap = self.running - bound
        if math.isfinite(gap) and math.isfinite(margin) and abs(gap) > margin:
            return gap > 0.0
        return self._exact() > bound


@dataclass
class ValidityMonitor:
    """Windowed NIS of each sensor against its chi-square band (see the module docstring)."""

    policy: DetectionPolicy
    dt: float
    flags: list = field(default_factory=list)

    def __post_init__(self):
        self._n = max(int(round(self.policy.validity_window / self.dt)), 1)
        self._buf: dict[str, _Window] = {}
        self._out_since: dict[str, float] = {}
        self._flagged: set[str] = set()
        self._tail = 0.5 * (1.0 - self.policy.validity_probability)

    def update(self, sensor: str, t: float, nis: float, dof: int) -> ValidityFlag | None:
        """Book one update's NIS; return a new flag when the sensor has just been found inconsistent."""
        window = self._buf.get(sensor)
        if window is None:
            window = self._buf[sensor] = _Window(self._n)
        window.append(float(t), float(nis), int(dof))
        if len(window) < self._n:
            return None
        side = "high" if window.exceeds(_upper_bound(self._tail, window.dof_sum)) else None
        if side is None:
            self._out_since.pop(sensor, None)
            return None
        since = self._out_since.setdefault(sensor, t)
        if t - since >= self.policy.validity_time and sensor not in self._flagged:
            self._flagged.add(sensor)
            flag = ValidityFlag(sensor, since, t, side)
            self.flags.append(flag)
            return flag
        return None

    def rewind(self, t: float) -> None:
        """Forget every update after ``t`` (the supervisor went back there to process them again) and the
        flags they raised: a sample processed twice counts once, and one a re-processing isolated counts not."""
        for sensor, window in self._buf.items():
            window.drop_after(t)
            if self._out_since.get(sensor, -np.inf) > t:
                del self._out_since[sensor]
        for f in self.flags:
            if f.time > t:
                self._flagged.discard(f.sensor)
        self.flags[:] = [f for f in self.flags if f.time <= t]
