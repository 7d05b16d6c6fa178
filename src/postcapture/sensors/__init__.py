"""Sensor models: truth histories in, noisy :class:`Measurements` out.

Every model samples the truth at its own rate (``t = t0 + k / rate``; the truth grid must contain
those instants), draws every random number from an explicit ``numpy.random.Generator``, and can drop
samples (NaN values, ``valid`` False). Parameters are frozen dataclasses validated on construction;
:mod:`postcapture.sensors.profiles` holds the named ``reference`` and ``realistic`` sets.

This package imports only :mod:`postcapture.core`, numpy and scipy.
"""

from postcapture.sensors.accelerometer import AccelerometerParams, measure_accelerometer
from postcapture.sensors.gyroscope import GyroParams, measure_gyro
from postcapture.sensors.joints import JointSensorParams, measure_joint_angles
from postcapture.sensors.profiles import PROFILES, SensorProfile, get_profile, realistic, reference
from postcapture.sensors.record import Measurements
from postcapture.sensors.star_tracker import StarTrackerParams, measure_star_tracker

__all__ = [
    "Measurements",
    "StarTrackerParams",
    "measure_star_tracker",
    "GyroParams",
    "measure_gyro",
    "AccelerometerParams",
    "measure_accelerometer",
    "JointSensorParams",
    "measure_joint_angles",
    "SensorProfile",
    "PROFILES",
    "get_profile",
    "reference",
    "realistic",
]
