"""Star tracker: the attitude ``q_BN`` with small-angle noise, tighter across the boresight than about it."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from postcapture.core import rotations as rot
from postcapture.core.errors import DimensionError
from postcapture.sensors._common import Checker, apply_dropouts, sample_truth
from postcapture.sensors.record import Measurements

__all__ = ["StarTrackerParams", "measure_star_tracker"]


@dataclass(frozen=True, slots=True)
class StarTrackerParams:
    """Noise model of a star tracker whose frame is fixed in the body.

    Parameters
    ----------
    sigma_cross : float
        1-sigma rotation error about each axis perpendicular to the boresight (rad).
    sigma_roll : float
        1-sigma rotation error about the boresight (rad); several times ``sigma_cross`` for a real unit.
    rate : float
        Sample rate (Hz).
    boresight_B : array_like, shape (3,)
        Boresight direction in body components (normalised on construction).
    dropout_probability : float
        Probability in [0, 1) that a sample is missing.

    Raises
    ------
    ScenarioError
        Listing every invalid field.
    """

    sigma_cross: float
    sigma_roll: float
    rate: float = 10.0
    boresight_B: np.ndarray = field(default_factory=lambda: np.array([0.0, 0.0, 1.0]))
    dropout_probability: float = 0.0

    def __post_init__(self):
        check = Checker(self)
        check.number("sigma_cross")
        check.number("sigma_roll")
        check.number("rate", positive=True)
        check.vector("boresight_B", nonzero=True)
        check.number("dropout_probability", below_one=True)
        check.done()
        b = self.boresight_B / np.linalg.norm(self.boresight_B)
        b.setflags(write=False)
        object.__setattr__(self, "boresight_B", b)

    def sensor_axes_B(self) -> np.ndarray:
        """Orthonormal sensor axes ``(e1, e2, boresight)``: the columns of a (3, 3) array, body components."""
        b = self.boresight_B
        helper = np.eye(3)[int(np.argmin(np.abs(b)))]
        e1 = np.cross(helper, b)
        e1 /= np.linalg.norm(e1)
        return np.column_stack([e1, np.cross(b, e1), b])

    def covariance(self) -> np.ndarray:
        """Measurement-noise covariance of the rotation error in body components (rad^2), shape (3, 3).

        ``R_B = sigma_cross^2 (I - b b^T) + sigma_roll^2 b b^T`` with ``b`` the boresight.
        """
        bbT = np.outer(self.boresight_B, self.boresight_B)
        return self.sigma_cross**2 * (np.eye(3) - bbT) + self.sigma_roll**2 * bbT


def measure_star_tracker(params: StarTrackerParams, t, q_BN, *, rng: np.random.Generator,
                         t_start: float | None = None, t_end: float | None = None) -> Measurements:
    """Sample the true attitude and corrupt it: ``q_meas = box_plus(q_BN, dtheta_B)``.

    Parameters
    ----------
    params : StarTrackerParams
        Noise model and rate.
    t : array_like, shape (n_t,)
        Truth time grid (s); it must contain every sample instant ``t_start + k / rate``.
    q_BN : array_like, shape (4, n_t)
        True attitude of the body B relative to N, scalar-first.
    rng : numpy.random.Generator
        Source of every random draw.
    t_start, t_end : float, optional
        First and last sample instants (s); the ends of the truth grid by default.

    Returns
    -------
    Measurements
        ``values`` shape (4, n): measured ``q_BN`` (w >= 0), NaN on dropouts. ``truth`` holds
        ``"q_BN"`` (4, n) and the rotation error ``"dtheta_B"`` (3, n) in body components.

    Raises
    ------
    TimeGridError
        If a sample instant is not on the truth grid.
    DimensionError
        If ``q_BN`` does not have shape (4, n_t).

    Notes
    -----
    The error is drawn in the sensor frame, ``sigma_cross`` about its two cross-boresight axes and
    ``sigma_roll`` about the boresight, then expressed in B; it is a right (body-frame) perturbation,
    the convention of :func:`postcapture.core.rotations.box_plus`.
    """
    ts, sampled = sample_truth("star_tracker", t, {"q_BN": q_BN}, params.rate, t_start, t_end)
    if sampled["q_BN"].shape[0] != 4:
        raise DimensionError(f"star_tracker: `q_BN` must have shape (4, n_t); found {np.shape(q_BN)}")
    q_true = rot.normalize(sampled["q_BN"])
    n = ts.size
    sig = np.array([params.sigma_cross, params.sigma_cross, params.sigma_roll])
    dtheta_B = params.sensor_axes_B() @ (sig[:, None] * rng.standard_normal((3, n)))
    q_meas = rot.box_plus(q_true, dtheta_B)
    values, valid = apply_dropouts(q_meas, params.dropout_probability, rng)
    return Measurements("star_tracker", ts, values, valid, "-", params.rate,
                        {"q_BN": q_true, "dtheta_B": dtheta_B})
