"""Named sensor profiles: ``reference`` (the reference work's tuning) and ``realistic`` (flight-class units).

This module is where datasheet units (arcsec, deg/h, deg/sqrt(h), micro-g) become SI, through the
factors of :mod:`postcapture.core.units`; every number below states its source or says it is an
assumption. A scenario picks a profile by name and may override single fields
(``dataclasses.replace``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from postcapture.core.errors import Problem, ScenarioError
from postcapture.core.units import ARCSEC, DEG_PER_HOUR, DEG_PER_SQRT_HOUR, HOUR, MICRO_G
from postcapture.sensors.accelerometer import AccelerometerParams
from postcapture.sensors.gyroscope import GyroParams
from postcapture.sensors.joints import JointSensorParams
from postcapture.sensors.star_tracker import StarTrackerParams

__all__ = ["SensorProfile", "reference", "realistic", "PROFILES", "get_profile"]


@dataclass(frozen=True, slots=True)
class SensorProfile:
    """The parameters of every sensor of the chaser, under one name.

    Parameters
    ----------
    name : str
        Profile name.
    star_tracker : StarTrackerParams
    gyro : GyroParams
    accelerometer : AccelerometerParams
    joints : JointSensorParams
    """

    name: str
    star_tracker: StarTrackerParams
    gyro: GyroParams
    accelerometer: AccelerometerParams
    joints: JointSensorParams


def reference() -> SensorProfile:
    """The reference work's numbers (thesis summary, section 6; ``physical-data.md``).

    * Star tracker: R = 0.01^2 I3 rad^2, i.e. 0.01 rad (about 2063 arcsec) 1-sigma about every axis.
    * Gyro: the reference does not give its gyro; we take the textbook MEKF example's
      sigma_v = sqrt(10) 1e-7 rad/sqrt(s), sigma_u = sqrt(10) 1e-10 rad/s^1.5 (Crassidis & Junkins,
      Markley & Crassidis examples) and an initial bias of 0.1 deg/h per axis (assumption).
    * Accelerometer and joints: the reference does not say how noisy its data were. Its mass filter's
      R_theta = diag(1e-4 I3, 1e-2 I7) (0.01 m/s^2, 0.1 rad/s^2) is a tuning: at that noise the mass
      would not be observable at all with this scenario's manoeuvre (Cramer-Rao bound ~300 kg from
      the accelerometer at fixed state). We simulate a navigation-grade accelerometer, 10 micro-g/sqrt(Hz)
      velocity random walk (3.1e-4 m/s^2 per 10 Hz mean specific force) without bias, and the
      realistic profile's joint encoders (the reference read joint accelerations; encoders are what the
      joints carry, and what a device outputs).
    * No scale-factor or misalignment errors: the reference's sensors have none.
    * Rates: 10 Hz for every sensor (assumption; the reference does not state them).
    """
    rate = 10.0
    return SensorProfile(
        name="reference",
        star_tracker=StarTrackerParams(sigma_cross=0.01, sigma_roll=0.01, rate=rate),
        gyro=GyroParams(
            sigma_v=math.sqrt(10.0) * 1e-7,
            sigma_u=math.sqrt(10.0) * 1e-10,
            rate=rate,
            initial_bias_B=np.full(3, 0.1 * DEG_PER_HOUR),
        ),
        accelerometer=AccelerometerParams(sigma=10.0 * MICRO_G * math.sqrt(rate), rate=rate),
        joints=_encoders(rate),
    )


ENCODER_RESOLUTION = 2.0 * math.pi / 2**20
"""One count of a 20-bit absolute encoder (rad)."""
ENCODER_NOISE = 5e-6
"""Read-out noise of a high-end interpolated encoder (rad, about 1 arcsec 1-sigma; assumption)."""
GYRO_SCALE_FACTOR_SIGMA = 100e-6
"""Astrix 120 datasheet scale factor (100 ppm), taken as a 1-sigma per axis."""
GYRO_MISALIGNMENT_SIGMA = 50e-6
"""Residual misalignment of each gyro axis towards the others after ground alignment (rad; assumption)."""
ACCEL_SCALE_FACTOR_SIGMA = 100e-6
"""Navigation-grade accelerometer scale factor, 1-sigma per axis (assumption, Groves 2013 ch. 4 order)."""
ACCEL_MISALIGNMENT_SIGMA = 100e-6
"""Accelerometer axis misalignment, 1-sigma (rad; assumption)."""


def _encoders(rate: float) -> JointSensorParams:
    return JointSensorParams(sigma=ENCODER_NOISE, resolution=ENCODER_RESOLUTION, rate=rate, n_joints=7)


def _unit_draw(seed: int, sigma_scale: float, sigma_mis: float) -> tuple[np.ndarray, np.ndarray]:
    """One unit's scale-factor and misalignment errors, a fixed draw from its datasheet's 1-sigma values."""
    rng = np.random.default_rng(seed)
    scale = sigma_scale * rng.standard_normal(3)
    mis = sigma_mis * rng.standard_normal((3, 3))
    np.fill_diagonal(mis, 0.0)
    return scale, mis


def realistic() -> SensorProfile:
    """Flight-class sensors.

    * Star tracker: 2 arcsec cross-boresight and 10 arcsec roll, 1-sigma, at 10 Hz (a "few arcsec"
      unit; high-end heads such as Sodern's HYDRA quote about 1 arcsec 3-sigma cross-boresight with a
      roll error several times larger), boresight along body +z.
    * Gyro, Astrix 120 class (Airbus datasheet): angle random walk 0.002 deg/sqrt(h)
      (5.8e-7 rad/sqrt(s)); bias stability 0.01 deg/h, modelled as a random walk that drifts 0.01 deg/h
      (1-sigma) in one hour: sigma_u = 0.01 deg/h / sqrt(3600 s) = 8.1e-10 rad/s^1.5. Initial bias
      0.05 deg/h per axis with mixed signs (assumption: residual after ground calibration). Scale factor
      100 ppm (datasheet) and misalignment 50 micro-rad (assumption) as 1-sigma values; this unit's errors
      are one fixed draw from them. 10 Hz angle increments.
    * Accelerometer, navigation grade (assumption, order of magnitude of navigation-grade units in
      Groves, *Principles of GNSS, Inertial, and Multisensor Integrated Navigation Systems*, 2nd ed.,
      2013, ch. 4): velocity random walk 10 micro-g/sqrt(Hz), so sigma = 10 micro-g sqrt(10 Hz) =
      3.1e-4 m/s^2 per 10 Hz mean specific force; bias 30 micro-g per axis; bias random walk 10 micro-g
      per sqrt(h); scale factor and misalignment 100 ppm and 100 micro-rad (1-sigma; one fixed draw).
    * Joint encoders: 20-bit absolute (one count 6.0e-6 rad) with 5e-6 rad read-out noise, 10 Hz.
    """
    rate = 10.0
    density = 10.0 * MICRO_G  # (m/s^2)/sqrt(Hz)
    g_scale, g_mis = _unit_draw(120, GYRO_SCALE_FACTOR_SIGMA, GYRO_MISALIGNMENT_SIGMA)
    a_scale, a_mis = _unit_draw(10, ACCEL_SCALE_FACTOR_SIGMA, ACCEL_MISALIGNMENT_SIGMA)
    return SensorProfile(
        name="realistic",
        star_tracker=StarTrackerParams(sigma_cross=2.0 * ARCSEC, sigma_roll=10.0 * ARCSEC, rate=rate),
        gyro=GyroParams(
            sigma_v=0.002 * DEG_PER_SQRT_HOUR,
            sigma_u=0.01 * DEG_PER_HOUR / math.sqrt(HOUR),
            rate=rate,
            initial_bias_B=np.array([0.05, -0.05, 0.05]) * DEG_PER_HOUR,
            scale_factor=g_scale,
            misalignment=g_mis,
            scale_factor_sigma=GYRO_SCALE_FACTOR_SIGMA,
            misalignment_sigma=GYRO_MISALIGNMENT_SIGMA,
        ),
        accelerometer=AccelerometerParams(
            sigma=density * math.sqrt(rate),
            rate=rate,
            bias_B=np.full(3, 30.0 * MICRO_G),
            sigma_bias_walk=10.0 * MICRO_G / math.sqrt(HOUR),
            scale_factor=a_scale,
            misalignment=a_mis,
        ),
        joints=_encoders(rate),
    )


PROFILES = {"reference": reference, "realistic": realistic}
"""Registry of the named profiles: name -> function returning a fresh :class:`SensorProfile`."""


def get_profile(name: str) -> SensorProfile:
    """Return the named profile.

    Raises
    ------
    ScenarioError
        If the name is unknown; the message lists the known names.
    """
    try:
        return PROFILES[name]()
    except KeyError:
        raise ScenarioError(
            [Problem("sensors.profile", " or ".join(repr(k) for k in PROFILES), repr(name))]
        ) from None
