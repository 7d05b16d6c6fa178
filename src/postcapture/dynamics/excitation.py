"""The known excitation of a scenario as a fast function of time ``u(t)``.

The scenario's profiles (:mod:`postcapture.config.excitation`) are vectorised numpy callables; the
integrator evaluates ``u`` at every stage of every step, so here they are compiled once into scalar
closures over :mod:`math`.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence

import numpy as np

from postcapture.config.excitation import Chirp, Sine, Step, Table, channel_index

__all__ = ["InputSchedule"]


def _scalar(profile) -> Callable[[float, bool], float]:
    """A scalar closure ``fn(t, left)``; ``left=True`` gives the left limit at a switching time."""
    start = profile.start
    stop = math.inf if profile.stop is None else profile.stop

    def on(t: float, left: bool) -> bool:
        return (start < t <= stop) if left else (start <= t < stop)

    if isinstance(profile, Step):
        a, rise = profile.amplitude, profile.rise_time
        if rise == 0.0:
            return lambda t, left: a if on(t, left) else 0.0

        def trapezoid(t, left):
            if not on(t, left):
                return 0.0
            return a * min(1.0, (t - start) / rise, (stop - t) / rise)

        return trapezoid
    if isinstance(profile, Sine):
        a, w, ph, off = profile.amplitude, 2 * math.pi * profile.frequency, profile.phase, profile.offset
        return lambda t, left: off + a * math.sin(w * (t - start) + ph) if on(t, left) else 0.0
    if isinstance(profile, Chirp):
        a, f0, ph = profile.amplitude, profile.f0, profile.phase
        rate = (profile.f1 - profile.f0) / (stop - start)
        two_pi = 2 * math.pi

        def chirp(t, left):
            if not on(t, left):
                return 0.0
            tau = t - start
            return a * math.sin(two_pi * (f0 * tau + 0.5 * rate * tau * tau) + ph)

        return chirp
    if isinstance(profile, Table):
        ts, vs = np.asarray(profile.t), np.asarray(profile.value)
        return lambda t, left: float(np.interp(t, ts, vs)) if on(t, left) else 0.0
    raise TypeError(f"unknown profile {type(profile).__name__}")


class InputSchedule:
    """``u(t)``: the sum of the scenario's excitation profiles on each input channel.

    Parameters
    ----------
    profiles : sequence of profiles
        The scenario's ``excitation`` entries.
    n_arm : int
        Number of arm joints; ``u`` has length ``6 + n_arm``.
    enabled : bool
        When False the schedule returns zeros (a free, unforced run).
    """

    def __init__(self, profiles: Sequence, n_arm: int, enabled: bool = True):
        self.n_inputs = 6 + n_arm
        self.profiles = tuple(profiles) if enabled else ()
        self._terms = [(channel_index(p.channel, n_arm), _scalar(p)) for p in self.profiles]

    def __call__(self, t: float, left: bool = False) -> np.ndarray:
        """Input vector at time ``t`` (s), shape ``(6 + n_arm,)``.

        Profiles switch on at ``start`` and off at ``stop`` (``[start, stop)``). With ``left=True`` the
        left limit is returned instead: an integrator evaluates the end of a step ``[t_k, t_k + h]`` that
        way, so a switch exactly on the step grid is seen by the next step only (no O(h) error).
        """
        u = [0.0] * self.n_inputs
        for i, fn in self._terms:
            u[i] += fn(t, left)
        return np.array(u)

    def switching_times(self) -> list[float]:
        """Every start and stop time of the profiles (s): steps should land on them."""
        times = {p.start for p in self.profiles} | {p.stop for p in self.profiles if p.stop is not None}
        return sorted(times)

    def sample(self, t) -> np.ndarray:
        """Inputs on a time grid, shape ``(6 + n_arm, len(t))``."""
        t = np.asarray(t, dtype=float)
        u = np.zeros((self.n_inputs, t.size))
        for p in self.profiles:
            u[channel_index(p.channel, self.n_inputs - 6)] += p(t)
        return u
