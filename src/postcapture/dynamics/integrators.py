"""Butcher tableaux of the Lie-group Runge-Kutta integrators (the compiled core runs them).

The core (``csrc/pc_integrator.c``, ``pc_jacobian.c``) integrates with any lower-triangular tableau:
Runge-Kutta-Munthe-Kaas in the chart ``q = q_k (+) xi`` centred on the step's start, explicit stages
evaluated, implicit ones solved by Newton's method in force form, step Jacobians from the implicit
function theorem at the converged stages.

* ``rk4``: classical RK4, order 4 (the Munthe-Kaas correction keeps order 4 on SE(3)); explicit, so
  its step is limited by the stiffest mode (about 2.8 / omega_max).
* ``sdirk4``: Hairer and Wanner's 5-stage SDIRK, order 4, L-stable and stiffly accurate.
* ``sdirk3``: Alexander's 3-stage SDIRK, order 3, L-stable and stiffly accurate; its step is not
  limited by the stiff arm-joint modes, which it damps.
* ``sdirk2``: Alexander's 2-stage SDIRK, order 2, L-stable.

The Python implementation that used to run them is the tests' oracle (``tests/lie_oracle.py``).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["Tableau", "TABLEAUX"]

_G3 = 0.43586652150845899941601945  # root of x^3 - 3x^2 + 3/2 x - 1/6 in (1/6, 1/2)
_G2 = 1.0 - 1.0 / np.sqrt(2.0)


@dataclass(frozen=True)
class Tableau:
    """A Butcher tableau with a lower-triangular ``A``."""

    name: str
    A: np.ndarray
    b: np.ndarray
    c: np.ndarray
    order: int
    l_stable: bool

    @property
    def stages(self) -> int:
        """Number of stages."""
        return len(self.b)

    @property
    def stiffly_accurate(self) -> bool:
        """True when the last stage is the step's result (``b`` is the last row of ``A``)."""
        return bool(np.array_equal(self.A[-1], self.b))


TABLEAUX = {
    "rk4": Tableau(
        "rk4",
        np.array([[0, 0, 0, 0], [0.5, 0, 0, 0], [0, 0.5, 0, 0], [0, 0, 1.0, 0]]),
        np.array([1 / 6, 1 / 3, 1 / 3, 1 / 6]),
        np.array([0, 0.5, 0.5, 1.0]),
        4,
        False,
    ),
    "sdirk2": Tableau(
        "sdirk2",
        np.array([[_G2, 0.0], [1 - _G2, _G2]]),
        np.array([1 - _G2, _G2]),
        np.array([_G2, 1.0]),
        2,
        True,
    ),
    # Hairer & Wanner's 5-stage SDIRK of order 4 (Solving ODEs II, table IV.6.5), L-stable, stiffly accurate
    "sdirk4": Tableau(
        "sdirk4",
        np.array(
            [
                [1 / 4, 0, 0, 0, 0],
                [1 / 2, 1 / 4, 0, 0, 0],
                [17 / 50, -1 / 25, 1 / 4, 0, 0],
                [371 / 1360, -137 / 2720, 15 / 544, 1 / 4, 0],
                [25 / 24, -49 / 48, 125 / 16, -85 / 12, 1 / 4],
            ]
        ),
        np.array([25 / 24, -49 / 48, 125 / 16, -85 / 12, 1 / 4]),
        np.array([1 / 4, 3 / 4, 11 / 20, 1 / 2, 1.0]),
        4,
        True,
    ),
    "sdirk3": Tableau(
        "sdirk3",
        np.array(
            [
                [_G3, 0.0, 0.0],
                [(1 - _G3) / 2, _G3, 0.0],
                [-(6 * _G3**2 - 16 * _G3 + 1) / 4, (6 * _G3**2 - 20 * _G3 + 5) / 4, _G3],
            ]
        ),
        np.array([-(6 * _G3**2 - 16 * _G3 + 1) / 4, (6 * _G3**2 - 20 * _G3 + 5) / 4, _G3]),
        np.array([_G3, (1 + _G3) / 2, 1.0]),
        3,
        True,
    ),
}
