r"""Rate-integrating gyroscope: angle increments with angle random walk, bias random walk, scale-factor
and misalignment errors (Markley & Crassidis discrete model, plus the datasheet's calibration terms).

A rate-integrating gyro outputs the angle turned over each sample period, ``delta_theta_k``, computed
inside the unit at a high rate (coning-compensated: the rotation vector from the body frame at
``t_k`` to that at ``t_k+1``). Sample ``k`` is reported as the mean rate ``delta_theta_k / dt`` over
``[t_k, t_k + dt]``:

.. math::

    b_{k+1} = b_k + \sigma_u \sqrt{\Delta t}\, n_{1,k}, \qquad
    \tilde\omega_k = (I + S + M)\, \bar\omega_k + \tfrac12 (b_k + b_{k+1})
        + \sqrt{\sigma_v^2/\Delta t + \sigma_u^2 \Delta t / 12}\; n_{2,k},

with ``S = diag(scale_factor)`` and ``M`` the misalignment (zero diagonal),

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

from postcapture.core.triad import axis_matrix
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
    scale_factor : array_like, shape (3,)
        Scale-factor error of each axis (relative: 1e-6 is 1 ppm).
    misalignment : array_like, shape (3, 3)
        Sensitivity of each axis to the two others (rad, small angles, zero diagonal).
    scale_factor_sigma, misalignment_sigma : float
        The datasheet's 1-sigma of those terms (relative, rad): what a filter should assume of a unit
        whose actual errors it does not know.
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
    scale_factor: np.ndarray = field(default_factory=lambda: np.zeros(3))
    misalignment: np.ndarray = field(default_factory=lambda: np.zeros((3, 3)))
    scale_factor_sigma: float = 0.0
    misalignment_sigma: float = 0.0
    dropout_probability: float = 0.0

    def __post_init__(self):
        check = Checker(self)
        check.number("sigma_v")
        check.number("scale_factor_sigma")
        check.number("misalignment_sigma")
        check.number("sigma_u")
        check.number("rate", positive=True)
        check.vector("initial_bias_B")
        check.vector("scale_factor")
        check.misalignment("misalignment")
        check.number("dropout_probability", below_one=True)
        check.done()

    @property
    def sample_sigma(self) -> float:
        """White one-sigma of one sample (rad/s): ``sqrt(sigma_v^2 / dt + sigma_u^2 dt / 12)``."""
        dt = 1.0 / self.rate
        return float(np.sqrt(self.sigma_v**2 / dt + self.sigma_u**2 * dt / 12.0))


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
        True rate of B relative to N averaged over each sample period, body components (rad/s): the
        rotation vector from ``t_k`` to ``t_k + dt`` over ``dt`` (see
        :func:`postcapture.studies.sensing.interval_mean_rate`). Sample ``k`` is taken at ``t_k``.
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
    C = axis_matrix(params.scale_factor, params.misalignment)
    values = C @ omega + 0.5 * (bias[:, :-1] + bias[:, 1:]) + sigma_white * rng.standard_normal((3, n))
    values, valid = apply_dropouts(values, params.dropout_probability, rng)
    return Measurements("gyro", ts, values, valid, "rad/s", params.rate,
                        {"bias_B": bias[:, :-1], "omega_BN_B": omega})
