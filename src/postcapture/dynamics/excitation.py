"""The known excitation of a scenario as a fast function of time ``u(t)``.

The scenario's profiles (:mod:`postcapture.config.excitation`) are evaluated here for the Python
reference path (the compiled core evaluates the same profiles in C for the production runs).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from postcapture.config.excitation import channel_index

__all__ = ["InputSchedule"]


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
        self._terms = [(channel_index(p.channel, n_arm), p) for p in self.profiles]

    def __call__(self, t: float, left: bool = False) -> np.ndarray:
        """Input vector at time ``t`` (s), shape ``(6 + n_arm,)``.

        Profiles switch on at ``start`` and off at ``stop`` (``[start, stop)``). With ``left=True`` the
        left limit is returned instead: an integrator evaluates the end of a step ``[t_k, t_k + h]`` that
        way, so a switch exactly on the step grid is seen by the next step only (no O(h) error).
        """
        u = np.zeros(self.n_inputs)
        for i, profile in self._terms:
            u[i] += float(profile(t, left))
        return u

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
