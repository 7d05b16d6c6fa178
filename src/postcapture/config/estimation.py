"""The scenario's estimation settings: initial mass error, filter step, seed and sensor-profile overrides.

Sensor profiles are built in (:mod:`postcapture.sensors.profiles`: ``reference`` and ``realistic``); a
scenario may override any of their numbers under ``[sensors.<profile>.<sensor>]``.
"""

from __future__ import annotations

from pydantic import Field

from postcapture.config.types import Frozen, NonNegativeFloat, PositiveFloat, Vec3

__all__ = ["StarTrackerSpec", "GyroSpec", "AccelerometerSpec", "JointSensorSpec", "SensorProfileSpec", "Estimation"]


class StarTrackerSpec(Frozen):
    """Overrides of a star tracker (rad, Hz)."""

    sigma_cross: PositiveFloat | None = None
    sigma_roll: PositiveFloat | None = None
    rate: PositiveFloat | None = None
    boresight_B: Vec3 | None = None
    dropout_probability: NonNegativeFloat | None = Field(default=None, lt=1.0)


class GyroSpec(Frozen):
    """Overrides of a gyroscope: angle random walk (rad/sqrt(s)), bias walk (rad/s^1.5), initial bias (rad/s)."""

    sigma_v: NonNegativeFloat | None = None
    sigma_u: NonNegativeFloat | None = None
    rate: PositiveFloat | None = None
    initial_bias_B: Vec3 | None = None
    dropout_probability: NonNegativeFloat | None = Field(default=None, lt=1.0)


class AccelerometerSpec(Frozen):
    """Overrides of the accelerometer: white noise (m/s^2), bias (m/s^2), bias walk (m/s^2.5)."""

    sigma: NonNegativeFloat | None = None
    rate: PositiveFloat | None = None
    bias_B: Vec3 | None = None
    sigma_bias_walk: NonNegativeFloat | None = None
    dropout_probability: NonNegativeFloat | None = Field(default=None, lt=1.0)


class JointSensorSpec(Frozen):
    """Overrides of the arm joint-acceleration sensors (rad/s^2)."""

    sigma: NonNegativeFloat | None = None
    rate: PositiveFloat | None = None
    dropout_probability: NonNegativeFloat | None = Field(default=None, lt=1.0)


class SensorProfileSpec(Frozen):
    """Overrides of one built-in sensor profile."""

    star_tracker: StarTrackerSpec = StarTrackerSpec()
    gyro: GyroSpec = GyroSpec()
    accelerometer: AccelerometerSpec = AccelerometerSpec()
    joints: JointSensorSpec = JointSensorSpec()


class Estimation(Frozen):
    """Settings of the main job's estimators.

    ``initial_mass_error`` (kg) is added to the true target mass to start every mass estimate.
    """

    initial_mass_error: float = -100.0
    filter_step: PositiveFloat = 0.1
    seed: int = Field(default=0, ge=0)
    sensors: dict[str, SensorProfileSpec] = Field(default_factory=dict)
