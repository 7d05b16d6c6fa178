"""Accelerometer on the chaser: velocity increments with white noise, bias, bias walk, scale factor, misalignment.

A navigation accelerometer triad outputs the velocity increment over each sample period, the specific
force integrated inside the unit (sculling-compensated) and expressed in the body frame at the start of
the period, ``delta_v_k = C_{B_k N} (integral of the specific force in N over [t_k, t_k + dt])``. Sample
``k`` is reported as the mean specific force ``delta_v_k / dt`` (m/s^2), which, unlike an instantaneous
sample, converges with the truth's step: the arm's unresolved modes fold into instantaneous samples, not
into their integral.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from postcapture.core.triad import axis_matrix
from postcapture.sensors._common import Checker, apply_dropouts, sample_truth
from postcapture.sensors.record import Measurements

__all__ = ["AccelerometerParams", "measure_accelerometer"]


@dataclass(frozen=True, slots=True)
class AccelerometerParams:
    """Noise model of a three-axis accelerometer aligned with the body axes.

    Parameters
    ----------
    sigma : float
        1-sigma white noise of one sample's mean specific force (m/s^2): a datasheet velocity random
        walk ``d`` in (m/s^2)/sqrt(Hz) gives ``sigma = d sqrt(rate)``.
    rate : float
        Sample rate (Hz).
    bias_B : array_like, shape (3,)
        Bias at the first sample (m/s^2), body components.
    sigma_bias_walk : float
        Bias random walk (m/s^2.5): ``b(k+1) = b(k) + sigma_bias_walk sqrt(dt) n``; 0 for a constant bias.
    scale_factor : array_like, shape (3,)
        Scale-factor error of each axis (relative: 1e-6 is 1 ppm).
    misalignment : array_like, shape (3, 3)
        Sensitivity of each axis to the two others (rad, small angles, zero diagonal).
    dropout_probability : float
        Probability in [0, 1) that a sample is missing.

    Raises
    ------
    ScenarioError
        Listing every invalid field.
    """

    sigma: float
    rate: float = 10.0
    bias_B: np.ndarray = field(default_factory=lambda: np.zeros(3))
    sigma_bias_walk: float = 0.0
    scale_factor: np.ndarray = field(default_factory=lambda: np.zeros(3))
    misalignment: np.ndarray = field(default_factory=lambda: np.zeros((3, 3)))
    dropout_probability: float = 0.0

    def __post_init__(self):
        check = Checker(self)
        check.number("sigma")
        check.number("rate", positive=True)
        check.vector("bias_B")
        check.number("sigma_bias_walk")
        check.vector("scale_factor")
        check.misalignment("misalignment")
        check.number("dropout_probability", below_one=True)
        check.done()


def measure_accelerometer(params: AccelerometerParams, t, f_B, *, rng: np.random.Generator,
                          t_start: float | None = None, t_end: float | None = None) -> Measurements:
    """Sample the true mean specific force and corrupt it: ``f_meas = (I + S + M) f_B + b_k + sigma n``.

    Parameters
    ----------
    params : AccelerometerParams
        Noise model and rate.
    t : array_like, shape (n_t,)
        Truth time grid (s); it must contain every sample instant.
    f_B : array_like, shape (3, n_t)
        True mean specific force over each sample period at the sensor, ``delta_v_k / dt``, in the body
        frame at the period's start (m/s^2; see :func:`postcapture.studies.sensing.interval_mean_specific_force`).
    rng : numpy.random.Generator
        Source of every random draw.
    t_start, t_end : float, optional
        First and last sample instants (s); the ends of the truth grid by default.

    Returns
    -------
    Measurements
        ``values`` shape (3, n) (m/s^2), NaN on dropouts; ``truth`` holds ``"bias_B"`` (3, n) and ``"f_B"``.

    Raises
    ------
    TimeGridError
        If a sample instant is not on the truth grid.
    """
    ts, sampled = sample_truth("accelerometer", t, {"f_B": f_B}, params.rate, t_start, t_end)
    f = sampled["f_B"]
    n = ts.size
    dt = 1.0 / params.rate
    steps = params.sigma_bias_walk * np.sqrt(dt) * rng.standard_normal((3, n - 1))
    bias = params.bias_B[:, None] + np.concatenate([np.zeros((3, 1)), np.cumsum(steps, axis=1)], axis=1)
    values = axis_matrix(params.scale_factor, params.misalignment) @ f + bias
    values = values + params.sigma * rng.standard_normal((3, n))
    values, valid = apply_dropouts(values, params.dropout_probability, rng)
    return Measurements("accelerometer", ts, values, valid, "m/s^2", params.rate, {"bias_B": bias, "f_B": f})
