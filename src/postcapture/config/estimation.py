"""The scenario's estimation settings: initial mass error, filter step, seed, sensor-profile overrides, tunings.

Sensor profiles are built in (:mod:`postcapture.sensors.profiles`: ``reference`` and ``realistic``); a
scenario may override any of their numbers under ``[estimation.sensors.<profile>.<sensor>]``, and any
filter tuning under ``[estimation.tuning.<profile>]``. A tuning left out is derived from the profile's
sensors, the target's nominal mass and the declared ``[uncertainty]`` (see
:func:`postcapture.studies.tuning.resolve_tuning`, which documents every default).
"""

from __future__ import annotations

from typing import Annotated, Literal

import numpy as np
from pydantic import Field, model_validator

from postcapture.config.types import MAX_MASS, Frequency, Frozen, Mass, Seed, problem, quantity, vector

Probability = quantity("1", ge=0.0, lt=1.0)

__all__ = ["StarTrackerSpec", "GyroSpec", "AccelerometerSpec", "JointSensorSpec", "SensorProfileSpec", "FilterTuning",
           "Estimation"]


class StarTrackerSpec(Frozen):
    """Overrides of a star tracker (rad, Hz)."""

    sigma_cross: quantity("rad", gt=0.0, le=1.0) | None = None
    sigma_roll: quantity("rad", gt=0.0, le=1.0) | None = None
    rate: Frequency | None = None
    boresight_B: vector("1", 1.0e3) | None = None
    dropout_probability: Probability | None = None


class GyroSpec(Frozen):
    """Overrides of a gyroscope: angle random walk (rad/sqrt(s)), bias walk (rad/s^1.5), initial bias (rad/s),
    scale-factor errors (relative) and the datasheet's 1-sigma of them and of the misalignment."""

    sigma_v: quantity("rad/s^0.5", ge=0.0, le=1.0) | None = None
    sigma_u: quantity("rad/s^1.5", ge=0.0, le=1.0) | None = None
    rate: Frequency | None = None
    initial_bias_B: vector("rad/s", 0.01) | None = None
    scale_factor: vector("1", 0.01) | None = None
    scale_factor_sigma: quantity("1", ge=0.0, le=0.01) | None = None
    misalignment_sigma: quantity("rad", ge=0.0, le=0.01) | None = None
    dropout_probability: Probability | None = None


class AccelerometerSpec(Frozen):
    """Overrides of the accelerometer: velocity random walk as the white noise of one sample's mean specific
    force (m/s^2), bias (m/s^2), bias walk (m/s^2.5), scale-factor errors (relative)."""

    sigma: quantity("m/s^2", ge=0.0, le=10.0) | None = None
    rate: Frequency | None = None
    bias_B: vector("m/s^2", 1.0) | None = None
    sigma_bias_walk: quantity("m/s^2.5", ge=0.0, le=1.0) | None = None
    scale_factor: vector("1", 0.01) | None = None
    dropout_probability: Probability | None = None


class JointSensorSpec(Frozen):
    """Overrides of the arm's joint encoders: read-out noise and one count (rad)."""

    sigma: quantity("rad", ge=0.0, le=0.1) | None = None
    resolution: quantity("rad", ge=0.0, le=0.1) | None = None
    rate: Frequency | None = None
    dropout_probability: Probability | None = None


class SensorProfileSpec(Frozen):
    """Overrides of one built-in sensor profile."""

    star_tracker: StarTrackerSpec = StarTrackerSpec()
    gyro: GyroSpec = GyroSpec()
    accelerometer: AccelerometerSpec = AccelerometerSpec()
    joints: JointSensorSpec = JointSensorSpec()


ParameterGroup = Literal["target", "panel_bending", "panel_torsion", "panel_damping", "arm_stiffness", "arm_damping"]


class FilterTuning(Frozen):
    """Tunings of the filters under one sensor profile; None means derived (SI units throughout).

    Parameters
    ----------
    star_tracker_sigma : float
        Star-tracker 1-sigma the attitude filters assume (rad).
    attitude_process_sigma : float
        Attitude EKF process noise per filter step (rad).
    attitude_initial_sigma : float
        Initial attitude 1-sigma of every filter (rad); the initial attitude errors are drawn from it.
    gyro_bias_initial_sigma, accelerometer_bias_initial_sigma : float
        Initial bias 1-sigma per axis (rad/s, m/s^2).
    mass_accel_sigma, mass_joint_sigma : float
        The sigmoid mass filter's measurement 1-sigma (m/s^2, rad/s^2).
    mass_process_variance : (float, float)
        Its process noise on the sigmoid pre-image per step, at the start and at the end of the run.
    mass_bounds : (float, float)
        Its sigmoid bounds (kg), around the nominal target mass and the initial estimate.
    sigmoid_c : float
        Its sigmoid steepness (1/kg of pre-image).
    gate_probability : float
        Chi-square gate of every filter's innovations, in (0, 1).
    model_process_variance : float
        The joint EKF's process noise per step on every plant velocity coordinate.
    estimate, consider : list of str
        Parameter groups the recommended schemes estimate and consider (Schmidt), among ``target``,
        ``panel_bending``, ``panel_torsion``, ``panel_damping``, ``arm_stiffness``, ``arm_damping``.
    model_noise : float
        Their process noise per step on every plant velocity coordinate ((m/s)^2, (rad/s)^2): the model
        error no parameter describes.
    """

    star_tracker_sigma: quantity("rad", gt=0.0, le=1.0) | None = None
    attitude_process_sigma: quantity("rad", ge=0.0, le=1.0) | None = None
    attitude_initial_sigma: quantity("rad", gt=0.0, le=1.0) | None = None
    gyro_bias_initial_sigma: quantity("rad/s", gt=0.0, le=0.01) | None = None
    accelerometer_bias_initial_sigma: quantity("m/s^2", gt=0.0, le=1.0) | None = None
    mass_accel_sigma: quantity("m/s^2", gt=0.0, le=10.0) | None = None
    mass_joint_sigma: quantity("rad/s^2", gt=0.0, le=100.0) | None = None
    mass_process_variance: tuple[quantity("1", ge=0.0, le=1.0e6), quantity("1", ge=0.0, le=1.0e6)] | None = None
    mass_bounds: tuple[Mass, Mass] | None = None
    sigmoid_c: quantity("1/kg", gt=0.0, le=1.0e3) | None = None
    gate_probability: quantity("1", gt=0.0, lt=1.0) | None = None
    model_process_variance: quantity("(m/s)^2 or (rad/s)^2", ge=0.0, le=1.0e6) | None = None
    estimate: tuple[ParameterGroup, ...] | None = None
    consider: tuple[ParameterGroup, ...] | None = None
    model_noise: quantity("(m/s)^2 or (rad/s)^2", ge=0.0, le=1.0e6) | None = None

    @model_validator(mode="after")
    def _bounds(self):
        if self.mass_bounds is not None and not self.mass_bounds[1] > self.mass_bounds[0]:
            raise problem("mass_bounds as [lower, upper] with upper > lower (kg)", list(self.mass_bounds))
        both = sorted(set(self.estimate or ()) & set(self.consider or ()))
        if both:
            raise problem("each parameter group either estimated or considered, not both", both, "consider")
        return self


class Estimation(Frozen):
    """Settings of the main job's estimators.

    ``initial_mass_error`` (kg) is added to the nominal target mass to start every mass estimate (the
    filters' model is the nominal one, whatever the truth). ``filter_step`` (s) is the filters' cycle
    (one prediction and the updates of the samples taken at its end); the process model integrates each
    cycle with ``integrator`` in steps of ``model_step`` (s, a divisor of ``filter_step``). These are
    the filters' own settings; the truth's are ``[simulation]``'s.

    Attributes
    ----------
    initial_mass_error : float
        Added to the nominal target mass to start every mass estimate (kg).
    filter_step : float
        The filters' cycle (s); equal to ``[simulation] sample_period``.
    integrator : str
        The filters' process model's integrator.
    model_step : float
        Its step (s); ``filter_step`` must be a whole multiple of it.
    jacobian : str
        How the filters propagate their covariance over a cycle of k model steps: ``"first_step"`` with
        the exact Jacobian of the cycle's first step taken k times (one step's sensitivities; the state
        still takes every step), ``"every_step"`` with each step's own. An FMU plant (``--plant fmu:``)
        gives its communication step's own Jacobian, as ``"every_step"``.
    seed : int
        Seed of the sensor noise and the initial attitude errors.
    sensors : table
        Overrides of the built-in sensor profiles, ``[estimation.sensors.<profile>.<sensor>]``.
    tuning : table
        Filter tunings per profile, ``[estimation.tuning.<profile>]``.
    """

    initial_mass_error: quantity("kg", ge=-MAX_MASS, le=MAX_MASS) = -100.0
    filter_step: quantity("s", gt=0.0, le=1.0e3) = 0.1
    integrator: Literal["sdirk4", "sdirk3", "sdirk2", "rk4"] = "sdirk4"
    model_step: quantity("s", gt=0.0, le=1.0e3) = 0.025
    jacobian: Literal["first_step", "every_step"] = "first_step"
    seed: Seed = 0
    sensors: dict[str, SensorProfileSpec] = Field(default_factory=dict)
    tuning: dict[str, FilterTuning] = Field(default_factory=dict)

    @model_validator(mode="after")
    def _model_grid(self):
        ratio = self.filter_step / self.model_step
        if not np.isfinite(ratio) or abs(ratio - round(ratio)) > 1e-9 or round(ratio) < 1:
            raise problem(f"filter_step a whole multiple of model_step = {self.model_step}", self.filter_step)
        return self
