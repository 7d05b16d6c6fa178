r"""Rate gyroscope with angle random walk and bias random walk (Markley & Crassidis discrete model).

.. math::

    b_{k+1} = b_k + \sigma_u \sqrt{\Delta t}\, n_{1,k}, \qquad
    \tilde\omega_k = \omega_k + \tfrac12 (b_k + b_{k+1})
        + \sqrt{\sigma_v^2/\Delta t + \sigma_u^2 \Delta t / 12}\; n_{2,k},

with independent standard normal ``n_1``, ``n_2``. Integrated over ``[t_k, t_k + dt]`` this has the
exact statistics of the continuous model ``omega_meas = omega + b + eta_v``, ``b_dot = eta_u``
(spectral densities ``sigma_v^2`` and ``sigma_u^2``), which is what the MEKF's process noise assumes.

References
----------
F. L. Markley and J. L. Crassidis, *Fundamentals of Spacecraft Attitude Determination and Control*,
Springer, 2014, section 6.4 (gyro model) and 6.2.4 (MEKF).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from postcapture.sensors._common import Checker, apply_dropouts, sample_truth
from postcapture.sensors.record import Measurements

__all__ = ["GyroParams", "measure_gyro"]


@dataclass(frozen=True, slots=True)
class GyroParams:
    """Noise model of a three-axis rate gyro aligned with the body axes.

    Parameters
    ----------
    sigma_v : float
        Angle random walk (rad/sqrt(s)).
    sigma_u : float
        Bias random walk (rad/s^1.5).
    rate : float
        Sample rate (Hz); the sampling interval ``dt = 1 / rate`` enters the discrete model.
    initial_bias_B : array_like, shape (3,)
        Bias at the first sample (rad/s), body components.
    dropout_probability : float
        Probability in [0, 1) that a sample is missing.

    Raises
    ------
    ScenarioError
        Listing every invalid field.
    """

    sigma_v: float
    sigma_u: float
    rate: float = 10.0
    initial_bias_B: np.ndarray = field(default_factory=lambda: np.zeros(3))
    dropout_probability: float = 0.0

    def __post_init__(self):
        check = Checker(self)
        check.number("sigma_v")
        check.number("sigma_u")
        check.number("rate", positive=True)
        check.vector("initial_bias_B")
        check.number("dropout_probability", below_one=True)
        check.done()


def measure_gyro(params: GyroParams, t, omega_BN_B, *, rng: np.random.Generator,
                 t_start: float | None = None, t_end: float | None = None) -> Measurements:
    """Sample the true body rate and corrupt it with the discrete ARW + bias-random-walk model.

    Parameters
    ----------
    params : GyroParams
        Noise model and rate.
    t : array_like, shape (n_t,)
        Truth time grid (s); it must contain every sample instant ``t_start + k / rate``.
    omega_BN_B : array_like, shape (3, n_t)
        True rate of B relative to N, body components (rad/s). Sample ``k`` is taken at ``t_k`` and
        stands for the rate over ``[t_k, t_k + dt]``; pass interval-averaged rates for a
        rate-integrating gyro.
    rng : numpy.random.Generator
        Source of every random draw.
    t_start, t_end : float, optional
        First and last sample instants (s); the ends of the truth grid by default.

    Returns
    -------
    Measurements
        ``values`` shape (3, n): measured rate (rad/s), NaN on dropouts. ``truth`` holds
        ``"bias_B"`` (3, n), the true bias ``b_k`` at each sample, and ``"omega_BN_B"`` (3, n).

    Raises
    ------
    TimeGridError
        If a sample instant is not on the truth grid.
    """
    ts, sampled = sample_truth("gyro", t, {"omega_BN_B": omega_BN_B}, params.rate, t_start, t_end)
    omega = sampled["omega_BN_B"]
    n = ts.size
    dt = 1.0 / params.rate
    steps = params.sigma_u * np.sqrt(dt) * rng.standard_normal((3, n))
    walk = np.concatenate([np.zeros((3, 1)), np.cumsum(steps, axis=1)], axis=1)
    bias = params.initial_bias_B[:, None] + walk  # b_0 ... b_n
    sigma_white = np.sqrt(params.sigma_v**2 / dt + params.sigma_u**2 * dt / 12.0)
    values = omega + 0.5 * (bias[:, :-1] + bias[:, 1:]) + sigma_white * rng.standard_normal((3, n))
    values, valid = apply_dropouts(values, params.dropout_probability, rng)
    return Measurements("gyro", ts, values, valid, "rad/s", params.rate,
                        {"bias_B": bias[:, :-1], "omega_BN_B": omega})
