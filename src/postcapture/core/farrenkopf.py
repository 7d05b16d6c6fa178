r"""Farrenkopf's analytic steady-state accuracy of a gyro-driven attitude filter.

A filter that propagates the attitude with a gyro (angle random walk ``sigma_v``, bias random walk
``sigma_u``) and corrects it every ``dt`` with an attitude sensor of noise ``sigma_n`` reaches, per
axis, a steady-state error that depends only on those four numbers. It is the yardstick for the
MEKF (:mod:`postcapture.estimation.mekf`): a correctly built and tuned filter's empirical error
matches it.

References
----------
R. L. Farrenkopf, "Analytic steady-state accuracy solutions for two common spacecraft attitude
estimators", J. Guidance and Control 1(4), 1978. F. L. Markley, J. L. Crassidis, *Fundamentals of
Spacecraft Attitude Determination and Control*, Springer, 2014, section 6.4.
"""

from __future__ import annotations

import math
from typing import NamedTuple

__all__ = ["FarrenkopfSteadyState", "farrenkopf_steady_state"]


class FarrenkopfSteadyState(NamedTuple):
    """Steady-state 1-sigma errors of the single-axis gyro + attitude-sensor filter."""

    attitude_pre: float
    """Attitude error just before an update (rad)."""
    attitude_post: float
    """Attitude error just after an update (rad)."""
    bias_pre: float
    """Bias error before an update (rad/s)."""
    bias_post: float
    """Bias error after an update (rad/s)."""


def farrenkopf_steady_state(
    sigma_n: float, sigma_v: float, sigma_u: float, dt: float
) -> FarrenkopfSteadyState:
    r"""Farrenkopf's analytic steady-state accuracy of the discrete attitude/gyro-bias filter, per axis.

    Parameters
    ----------
    sigma_n : float
        Attitude-sensor 1-sigma noise about the axis (rad), positive.
    sigma_v : float
        Gyro angle random walk (rad/sqrt(s)).
    sigma_u : float
        Gyro bias random walk (rad/s^1.5).
    dt : float
        Interval between attitude measurements (s).

    Returns
    -------
    FarrenkopfSteadyState

    Notes
    -----
    With :math:`S_v = \sigma_v \sqrt{dt}/\sigma_n`, :math:`S_u = \sigma_u dt^{3/2}/\sigma_n`,

    .. math::

        \gamma = \tfrac14\left(S_u + \sqrt{16 + 4 S_v^2 + S_u^2/3}\right), \qquad
        \xi = \gamma + \sqrt{\gamma^2 - 1},

        P^-_{\theta} = \sigma_n^2 (\xi^2 - 1), \quad P^+_{\theta} = \sigma_n^2 (1 - \xi^{-2}), \quad
        P^+_b = \frac{\sigma_n^2}{dt^2}\left(S_u (\xi - \xi^{-1}) - S_u^2/2\right), \quad
        P^-_b = P^+_b + \sigma_u^2 dt.

    This is the exact steady state of the single-axis Riccati recursion with the process noise of
    :func:`postcapture.estimation.mekf.process_noise` and one measurement per ``dt`` (Farrenkopf 1978;
    Markley & Reynolds,
    J. Guidance, Control, and Dynamics 23(6), 2000; Markley & Crassidis 2014, section 6.4); it was
    re-derived for this module (the Riccati equation reduces to a palindromic quartic in
    :math:`\xi = \sqrt{1 + P^-_\theta/\sigma_n^2}`) and is checked against ``scipy.linalg.solve_discrete_are``
    in the tests.
    """
    if not sigma_n > 0 or not dt > 0 or sigma_v < 0 or sigma_u < 0:
        raise ValueError("need sigma_n > 0, dt > 0, sigma_v >= 0 and sigma_u >= 0")
    s_v = sigma_v * math.sqrt(dt) / sigma_n
    s_u = sigma_u * dt**1.5 / sigma_n
    # written without cancellation: gamma - 1 and xi^2 - 1 are tiny for good gyros
    root = math.sqrt(16.0 + 4.0 * s_v**2 + s_u**2 / 3.0)
    gamma_m1 = 0.25 * (s_u + (4.0 * s_v**2 + s_u**2 / 3.0) / (root + 4.0))
    sqrt_g2m1 = math.sqrt(gamma_m1 * (gamma_m1 + 2.0))
    xi = 1.0 + gamma_m1 + sqrt_g2m1
    xi2_m1 = (gamma_m1 + sqrt_g2m1) * (xi + 1.0)
    att_pre = sigma_n * math.sqrt(xi2_m1)
    att_post = sigma_n * math.sqrt(xi2_m1) / xi
    bias_post_var = (sigma_n / dt) ** 2 * max(s_u * xi2_m1 / xi - 0.5 * s_u**2, 0.0)
    bias_pre = math.sqrt(bias_post_var + sigma_u**2 * dt)
    bias_post = math.sqrt(bias_post_var)
    return FarrenkopfSteadyState(float(att_pre), float(att_post), float(bias_pre), float(bias_post))
