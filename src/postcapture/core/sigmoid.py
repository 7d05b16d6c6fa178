r"""The sigmoid map that keeps an estimated parameter inside an open interval ``(b, a)``.

The mass filter estimates an unconstrained ``x`` and reads the parameter through

.. math::

    \theta = b + \frac{a - b}{1 + e^{-c x}}, \qquad
    x = -\frac{1}{c} \ln\frac{a - \theta}{\theta - b}, \qquad
    \frac{d\theta}{dx} = \frac{c (\theta - b)(a - \theta)}{a - b}.

This is the reference's equation 4 in its correct form (the typeset equation in the thesis summary is
garbled); its defaults are ``c = 0.001``, ``a = 9000``, ``b = 5000`` (kg for Envisat's mass). At
``x = 0`` the map gives the midpoint ``(a + b)/2`` with slope ``c (a - b)/4``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.special import expit, logit

from postcapture.core.errors import DomainError, Problem, ScenarioError

__all__ = ["SigmoidMap"]


@dataclass(frozen=True, slots=True)
class SigmoidMap:
    """Bijection between an unconstrained ``x`` and a parameter ``theta`` in ``(b, a)``.

    Parameters
    ----------
    a : float
        Upper bound of ``theta`` (unit of theta; kg for a mass).
    b : float
        Lower bound of ``theta``, ``b < a``.
    c : float
        Steepness (1 / unit of x), positive.

    Raises
    ------
    ScenarioError
        If ``a <= b``, ``c <= 0`` or a value is not finite; every problem is listed.

    Examples
    --------
    >>> m = SigmoidMap()
    >>> float(m.forward(0.0)), float(m.derivative(0.0))
    (7000.0, 1.0)
    >>> round(float(m.forward(m.inverse(7827.9))), 9)
    7827.9
    """

    a: float = 9000.0
    b: float = 5000.0
    c: float = 0.001

    def __post_init__(self):
        problems = []
        for name in ("a", "b", "c"):
            value = getattr(self, name)
            try:
                ok = np.isfinite(float(value))
            except (TypeError, ValueError):
                ok = False
            if not ok:
                problems.append(Problem(f"SigmoidMap.{name}", "a finite number", repr(value)))
            else:
                object.__setattr__(self, name, float(value))
        if not problems:
            if not self.a > self.b:
                problems.append(Problem("SigmoidMap.a", f"a > b = {self.b}", repr(self.a)))
            if not self.c > 0.0:
                problems.append(Problem("SigmoidMap.c", "c > 0", repr(self.c)))
        if problems:
            raise ScenarioError(problems, source="SigmoidMap")

    def forward(self, x):
        """Parameter ``theta = b + (a - b) / (1 + exp(-c x))`` for any real ``x`` (scalar or array)."""
        return self.b + (self.a - self.b) * expit(self.c * np.asarray(x, dtype=float))

    def inverse(self, theta):
        """Unconstrained ``x = -(1/c) ln((a - theta)/(theta - b))``.

        Raises
        ------
        DomainError
            If a ``theta`` is not strictly inside ``(b, a)``.
        """
        theta = np.asarray(theta, dtype=float)
        inside = (theta > self.b) & (theta < self.a)
        if not np.all(inside):
            bad = theta[~inside] if theta.ndim else theta
            raise DomainError(
                f"theta must lie strictly inside (b, a) = ({self.b:g}, {self.a:g}); found {np.ravel(bad)[:3]}"
            )
        return logit((theta - self.b) / (self.a - self.b)) / self.c

    def derivative(self, x):
        """Slope ``dtheta/dx = c (theta - b)(a - theta)/(a - b)`` at ``x`` (scalar or array)."""
        cx = self.c * np.asarray(x, dtype=float)
        # (theta - b)(a - theta)/(a - b) = (a - b) s(cx) s(-cx): no cancellation in the tails
        return self.c * (self.a - self.b) * expit(cx) * expit(-cx)
