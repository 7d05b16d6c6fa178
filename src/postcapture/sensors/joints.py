"""Arm joint sensors giving joint accelerations with white noise, as the reference used them."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from postcapture.core.errors import DimensionError
from postcapture.sensors._common import Checker, apply_dropouts, sample_truth
from postcapture.sensors.record import Measurements

__all__ = ["JointSensorParams", "measure_joint_accelerations"]


@dataclass(frozen=True, slots=True)
class JointSensorParams:
    """Noise model of the arm's joint-acceleration measurements.

    Parameters
    ----------
    sigma : float
        1-sigma white noise of one sample (rad/s^2), the same on every joint.
    rate : float
        Sample rate (Hz).
    n_joints : int
        Number of joints (7 for the reference arm).
    dropout_probability : float
        Probability in [0, 1) that a sample (all joints at once) is missing.

    Raises
    ------
    ScenarioError
        Listing every invalid field.
    """

    sigma: float
    rate: float = 10.0
    n_joints: int = 7
    dropout_probability: float = 0.0

    def __post_init__(self):
        check = Checker(self)
        check.number("sigma")
        check.number("rate", positive=True)
        check.integer("n_joints")
        check.number("dropout_probability", below_one=True)
        check.done()


def measure_joint_accelerations(params: JointSensorParams, t, qdd, *, rng: np.random.Generator,
                                t_start: float | None = None, t_end: float | None = None) -> Measurements:
    """Sample the true joint accelerations and add white noise.

    Parameters
    ----------
    params : JointSensorParams
        Noise model and rate.
    t : array_like, shape (n_t,)
        Truth time grid (s); it must contain every sample instant.
    qdd : array_like, shape (n_joints, n_t)
        True joint accelerations (rad/s^2).
    rng : numpy.random.Generator
        Source of every random draw.
    t_start, t_end : float, optional
        First and last sample instants (s); the ends of the truth grid by default.

    Returns
    -------
    Measurements
        ``values`` shape (n_joints, n) (rad/s^2), NaN on dropouts; ``truth`` holds ``"qdd"``.

    Raises
    ------
    DimensionError
        If ``qdd`` does not have ``n_joints`` rows.
    TimeGridError
        If a sample instant is not on the truth grid.
    """
    ts, sampled = sample_truth("joints", t, {"qdd": qdd}, params.rate, t_start, t_end)
    true = sampled["qdd"]
    if true.shape[0] != params.n_joints:
        raise DimensionError(f"joints: `qdd` must have shape ({params.n_joints}, n_t); found {np.shape(qdd)}")
    values = true + params.sigma * rng.standard_normal(true.shape)
    values, valid = apply_dropouts(values, params.dropout_probability, rng)
    return Measurements("joints", ts, values, valid, "rad/s^2", params.rate, {"qdd": true})
