"""Arm joint encoders: the link-side joint angles, with white noise and the encoder's quantisation.

An absolute encoder reads the angle of its joint at each sample instant, to its resolution (one count
of ``resolution`` rad), with a small read-out noise. A rate or an acceleration is not a device output:
a user who wants one differentiates the angles through a filter of their choosing; the estimators read
the angles themselves, which converge with the truth's step where sampled accelerations do not (the
arm's unresolved modes fold into instantaneous accelerations).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from postcapture.core.errors import DimensionError
from postcapture.sensors._common import Checker, apply_dropouts, sample_truth
from postcapture.sensors.record import Measurements

__all__ = ["JointSensorParams", "measure_joint_angles"]


@dataclass(frozen=True, slots=True)
class JointSensorParams:
    """Noise model of the arm's joint encoders.

    Parameters
    ----------
    sigma : float
        1-sigma white read-out noise of one sample (rad), the same on every joint.
    resolution : float
        One count of the encoder (rad); 0 for none. A 20-bit absolute encoder has ``2 pi / 2^20``
        (6.0e-6 rad).
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
    resolution: float = 0.0
    rate: float = 10.0
    n_joints: int = 7
    dropout_probability: float = 0.0

    def __post_init__(self):
        check = Checker(self)
        check.number("sigma")
        check.number("resolution")
        check.number("rate", positive=True)
        check.integer("n_joints")
        check.number("dropout_probability", below_one=True)
        check.done()

    @property
    def sample_sigma(self) -> float:
        """One-sigma error of one reading (rad): the noise and the quantisation's ``resolution / sqrt(12)``."""
        return float(np.sqrt(self.sigma**2 + self.resolution**2 / 12.0))


def measure_joint_angles(params: JointSensorParams, t, q_arm, *, rng: np.random.Generator,
                         t_start: float | None = None, t_end: float | None = None) -> Measurements:
    """Sample the true joint angles, add the read-out noise and quantise to the encoder's resolution.

    Parameters
    ----------
    params : JointSensorParams
        Noise model and rate.
    t : array_like, shape (n_t,)
        Truth time grid (s); it must contain every sample instant.
    q_arm : array_like, shape (n_joints, n_t)
        True link-side joint angles (rad).
    rng : numpy.random.Generator
        Source of every random draw.
    t_start, t_end : float, optional
        First and last sample instants (s); the ends of the truth grid by default.

    Returns
    -------
    Measurements
        ``values`` shape (n_joints, n) (rad), NaN on dropouts; ``truth`` holds ``"q_arm"``.

    Raises
    ------
    DimensionError
        If ``q_arm`` does not have ``n_joints`` rows.
    TimeGridError
        If a sample instant is not on the truth grid.
    """
    ts, sampled = sample_truth("joints", t, {"q_arm": q_arm}, params.rate, t_start, t_end)
    true = sampled["q_arm"]
    if true.shape[0] != params.n_joints:
        raise DimensionError(f"joints: `q_arm` must have shape ({params.n_joints}, n_t); found {np.shape(q_arm)}")
    values = true + params.sigma * rng.standard_normal(true.shape)
    if params.resolution > 0.0:
        values = np.round(values / params.resolution) * params.resolution
    values, valid = apply_dropouts(values, params.dropout_probability, rng)
    return Measurements("joints", ts, values, valid, "rad", params.rate, {"q_arm": true})
