"""The known excitation of a scenario as a fast function of time ``u(t)``.

The scenario's profiles (:mod:`postcapture.config.excitation`, validated data) are packed here by
:func:`pack_profiles` into the compiled core's layout and evaluated by the core's C code
(``pc_inputs_eval`` in ``csrc/pc_inputs.c``), the one implementation of the profile formulas: the
Python reference path reads them through :class:`InputSchedule`, the compiled plant and exported FMUs
through the same function inside the model.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from postcapture.config.excitation import Chirp, Sine, Step, Table, channel_index

__all__ = ["InputSchedule", "pack_profiles"]


def pack_profiles(profiles, n_arm: int):
    """Per profile: ints ``(kind, channel, table offset, table length)`` and doubles ``(start, stop, a,
    rise, w, phase, offset, f0, rate)``, then the concatenated table times and values."""
    ints, dbl, table_t, table_v = [], [], [], []
    for p in profiles:
        stop = math.inf if p.stop is None else p.stop
        start = p.start
        a = rise = w = phase = offset = f0 = rate = 0.0
        table = n_table = 0
        if isinstance(p, Step):
            kind, a, rise = 0, p.amplitude, p.rise_time
        elif isinstance(p, Sine):
            kind, a, w, phase, offset = 1, p.amplitude, 2 * math.pi * p.frequency, p.phase, p.offset
        elif isinstance(p, Chirp):
            kind, a, f0, phase = 2, p.amplitude, p.f0, p.phase
            rate = (p.f1 - p.f0) / (stop - start)
        elif isinstance(p, Table):
            kind, table, n_table = 3, len(table_t), len(p.t)
            table_t += list(p.t)
            table_v += list(p.value)
        else:
            raise TypeError(f"unknown excitation profile {type(p).__name__}")
        ints += [kind, channel_index(p.channel, n_arm), table, n_table]
        dbl += [start, stop, a, rise, w, phase, offset, f0, rate]
    return ints, dbl, table_t, table_v


def _or_none(a: np.ndarray):
    return a if a.size else None


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

    The profiles are packed once here; every evaluation is one call of the compiled core's
    ``pc_inputs_eval`` (the core is built on first use, see :mod:`postcapture.dynamics.compiled`).
    """

    def __init__(self, profiles: Sequence, n_arm: int, enabled: bool = True):
        self.n_inputs = 6 + n_arm
        self.profiles = tuple(profiles) if enabled else ()
        ints, dbl, table_t, table_v = pack_profiles(self.profiles, n_arm)
        self._ints = np.ascontiguousarray(ints, dtype=np.int32)
        self._dbl = np.ascontiguousarray(dbl, dtype=float)
        self._table_t = np.ascontiguousarray(table_t, dtype=float)
        self._table_v = np.ascontiguousarray(table_v, dtype=float)

    def _eval(self, t: np.ndarray, left: bool) -> np.ndarray:
        """``u`` at the times ``t`` (1-D, contiguous float), shape ``(len(t), n_inputs)``."""
        u = np.zeros((t.size, self.n_inputs))
        if not self.profiles or not t.size:
            return u
        from postcapture.dynamics.engine import engine

        engine().inputs_eval(len(self.profiles), _or_none(self._ints), _or_none(self._dbl), self._table_t.size,
                             _or_none(self._table_t), _or_none(self._table_v), self.n_inputs, t.size, t,
                             int(bool(left)), u)
        return u

    def __call__(self, t: float, left: bool = False) -> np.ndarray:
        """Input vector at time ``t`` (s), shape ``(6 + n_arm,)``.

        Profiles switch on at ``start`` and off at ``stop`` (``[start, stop)``). With ``left=True`` the
        left limit is returned instead: an integrator evaluates the end of a step ``[t_k, t_k + h]`` that
        way, so a switch exactly on the step grid is seen by the next step only (no O(h) error).
        """
        return self._eval(np.array([float(t)]), left)[0]

    def switching_times(self) -> list[float]:
        """Every start and stop time of the profiles (s): steps should land on them."""
        times = {p.start for p in self.profiles} | {p.stop for p in self.profiles if p.stop is not None}
        return sorted(times)

    def sample(self, t, left: bool = False) -> np.ndarray:
        """Inputs on a time grid, shape ``(6 + n_arm, len(t))``; ``left``: left limits (see ``__call__``)."""
        t = np.ascontiguousarray(t, dtype=float).ravel()
        return self._eval(t, left).T.copy()
