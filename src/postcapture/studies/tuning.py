"""Every filter tuning of a run, resolved: the scenario's ``[estimation.tuning.<profile>]`` or a derived default.

Defaults, per sensor profile (``reference``: the reference's own numbers; ``realistic``: matched to the
simulated sensors):

=================================  ==========================  =========================================
tuning                             reference                   realistic
=================================  ==========================  =========================================
``star_tracker_sigma``             0.01 rad                    the sensor's (2 / 10 arcsec cross / roll)
``attitude_process_sigma``         0.0007 rad per step         4e-7 rad per step
``attitude_initial_sigma``         0.02 rad                    twice the star tracker's
``gyro_bias_initial_sigma``        ``[uncertainty] gyro_bias``, else 0.2 deg/h
``accelerometer_bias_initial_...`` ``[uncertainty] accelerometer_bias``, else twice the profile's bias
                                   (at least 5e-5 m/s^2)
``mass_accel_sigma``, ``..joint``  0.01 m/s^2, 100 x encoder   the sensors'
``mass_process_variance``          20.1 to 0.1 (kg^2/step)     20.1 to 1e-4
``mass_bounds``                    the reference's (5000, 9000) kg scaled by nominal mass / 7827.9, widened
                                   to hold the initial estimate +- 3 prior sigmas (above the panels' mass)
``sigmoid_c``                      ``4 / (upper - lower)``: slope 1 kg per unit at the middle, as the
                                   reference's c = 0.001 on (5000, 9000)
``gate_probability``               0.9999
``model_process_variance``         1e-16 (joint EKF, per step on each plant velocity)
``model_noise``                    derived from the declared truth discretisation (the recommended schemes'
                                   model error left after their parameters; ``campaign.robust``)
=================================  ==========================  =========================================

The mass prior's 1-sigma is ``[uncertainty] target_mass`` (RMS about the nominal), else 10 % of the
nominal mass; the filters' initial covariance makes that sigma hold *in kg at the initial estimate*
(through the sigmoid's slope there), so a prior sigma means what it says wherever the estimate starts.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from postcapture.config.estimation import FilterTuning
from postcapture.config.schema import Scenario
from postcapture.core.errors import Problem, ScenarioError
from postcapture.core.units import DEG_PER_HOUR
from postcapture.sensors.profiles import SensorProfile

__all__ = ["ResolvedTuning", "resolve_tuning", "mass_prior_sigma", "sigmoid_prior_variance", "REFERENCE_MASS",
           "REFERENCE_BOUNDS"]

REFERENCE_MASS = 7827.9  # kg, Envisat: the reference's sigmoid bounds were set for it
REFERENCE_BOUNDS = (5000.0, 9000.0)  # kg, the reference's b and a


@dataclasses.dataclass(frozen=True)
class ResolvedTuning:
    """Every tuning with a value (SI); ``star_covariance`` and ``attitude_P0`` are (3, 3) matrices."""

    star_covariance: np.ndarray
    attitude_process_sigma: float
    attitude_P0: np.ndarray
    gyro_bias_initial_sigma: float
    accelerometer_bias_initial_sigma: float
    mass_accel_sigma: float
    mass_joint_sigma: float
    mass_process_variance: tuple[float, float]
    mass_bounds: tuple[float, float]
    sigmoid_c: float
    gate_probability: float
    model_process_variance: float
    mass_prior_sigma: float  # kg
    model_noise: float | dict | None  # None: derived from the declared truth discretisation (campaign.robust)
    discretisation_bias: np.ndarray | None = None  # (n_p, n_t): derived with the model noise (studies.robust)
    gyro_scale_sigma: float = 0.0  # relative, per axis: the gyro calibration prior (0: no calibration states)
    gyro_misalignment_sigma: float = 0.0  # rad, per off-diagonal term


def mass_prior_sigma(scenario: Scenario) -> float:
    """The filters' prior 1-sigma of the target mass (kg): declared, or 10 % of the nominal mass."""
    declared = scenario.uncertainty.offset("target_mass")
    return declared if declared > 0 else 0.1 * scenario.target.mass


def resolve_tuning(scenario: Scenario, profile_name: str, profile: SensorProfile, *,
                   initial_mass: float | None = None) -> ResolvedTuning:
    """The tunings of ``profile_name`` for ``scenario`` (see the module docstring for every default).

    Raises
    ------
    ScenarioError
        If the sigmoid bounds do not hold the nominal mass and the initial estimate, or lie below the
        target's panels (the message names ``estimation.tuning.<profile>.mass_bounds``).
    """
    given = scenario.estimation.tuning.get(profile_name, FilterTuning())
    ref = profile_name == "reference"
    unc = scenario.uncertainty
    m_nom = float(scenario.target.mass) if scenario.target is not None else float("nan")
    m0 = m_nom + scenario.estimation.initial_mass_error if initial_mass is None else float(initial_mass)
    st = profile.star_tracker

    if given.star_tracker_sigma is not None:
        R = given.star_tracker_sigma**2 * np.eye(3)
    else:
        R = 0.01**2 * np.eye(3) if ref else st.covariance()
    P0 = (given.attitude_initial_sigma**2 * np.eye(3) if given.attitude_initial_sigma is not None
          else (0.02**2 * np.eye(3) if ref else 4.0 * R))
    sigma_m = mass_prior_sigma(scenario) if scenario.target is not None else float("nan")
    if given.mass_bounds is not None:
        lo, hi = given.mass_bounds
    else:
        lo, hi = (b * m_nom / REFERENCE_MASS for b in REFERENCE_BOUNDS)
        panels = sum(p.mass for p in scenario.target.panels) if scenario.target is not None else 0.0
        lo = max(min(lo, m0 - 3.0 * sigma_m), panels + 0.01 * m_nom)
        hi = max(hi, m0 + 3.0 * sigma_m)
    where = f"estimation.tuning.{profile_name}.mass_bounds"
    if scenario.target is not None and not (lo < min(m0, m_nom) and max(m0, m_nom) < hi):
        raise ScenarioError([Problem(where, f"bounds holding the nominal mass {m_nom:g} kg and the initial estimate "
                                            f"{m0:g} kg", f"[{lo:g}, {hi:g}]")])
    acc_bias = unc.offset("accelerometer_bias") or max(2.0 * float(np.max(np.abs(profile.accelerometer.bias_B))), 5e-5)
    return ResolvedTuning(
        star_covariance=R,
        attitude_process_sigma=_pick(given.attitude_process_sigma, 0.0007 if ref else 4e-7),
        attitude_P0=P0,
        gyro_bias_initial_sigma=_pick(given.gyro_bias_initial_sigma, unc.offset("gyro_bias") or 0.2 * DEG_PER_HOUR),
        accelerometer_bias_initial_sigma=_pick(given.accelerometer_bias_initial_sigma, acc_bias),
        mass_accel_sigma=_pick(given.mass_accel_sigma, 0.01 if ref else profile.accelerometer.sigma),
        # the reference read joint accelerations with R 100 times their noise; its encoders get the same ratio
        mass_joint_sigma=_pick(given.mass_joint_sigma, (100.0 if ref else 1.0) * profile.joints.sample_sigma),
        mass_process_variance=tuple(given.mass_process_variance or ((20.1, 0.1) if ref else (20.1, 1e-4))),
        mass_bounds=(float(lo), float(hi)),
        sigmoid_c=_pick(given.sigmoid_c, 4.0 / (hi - lo)),
        gate_probability=_pick(given.gate_probability, 0.9999),
        model_process_variance=_pick(given.model_process_variance, 1e-16),
        mass_prior_sigma=sigma_m,
        model_noise=given.model_noise,
        gyro_scale_sigma=unc.offset("gyro_scale_factor") or profile.gyro.scale_factor_sigma,
        gyro_misalignment_sigma=unc.offset("gyro_misalignment") or profile.gyro.misalignment_sigma,
    )


def _pick(value, default) -> float:
    return float(default if value is None else value)


def sigmoid_prior_variance(tuning: ResolvedTuning, smap, m0: float) -> float:
    """Variance of the sigmoid pre-image that gives ``mass_prior_sigma`` in kg at the initial estimate ``m0``."""
    slope = float(smap.derivative(smap.inverse(m0)))
    return (tuning.mass_prior_sigma / slope) ** 2 if math.isfinite(slope) and slope > 0 else tuning.mass_prior_sigma**2
